//! Format detection: content first (PBF header, JSON `type`), the extension
//! for content that is neither, and `--format` forcing a reader.

use std::path::Path;

use citypvs::input::{Format, InputOptions, read_city_bytes};

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures")
            .join(name),
    )
    .unwrap()
}

fn forced(format: Format) -> InputOptions {
    InputOptions {
        format: Some(format),
        ..InputOptions::default()
    }
}

#[test]
fn content_wins_over_a_misleading_extension() {
    let options = InputOptions::default();
    // PBF bytes named like GeoJSON, GeoJSON named like PBF, CityJSON named .json.
    let pbf = read_city_bytes(&fixture("kotka.osm.pbf"), "kotka.geojson", &options).unwrap();
    let json = read_city_bytes(&fixture("kotka.geojson"), "kotka.pbf", &options).unwrap();
    let sorted_ids = |c: &citypvs::input::City| {
        let mut ids: Vec<String> = c.buildings.iter().map(|b| b.id.clone()).collect();
        ids.sort();
        ids
    };
    assert_eq!(pbf.buildings.len(), 2171);
    assert_eq!(sorted_ids(&pbf), sorted_ids(&json));
    let city = read_city_bytes(&fixture("input/small-2.0.city.json"), "x.json", &options).unwrap();
    assert_eq!(city.buildings.len(), 4);
}

#[test]
fn extension_decides_for_broken_content() {
    let options = InputOptions::default();
    let err = crate::common::error_of(
        read_city_bytes(b"\x00\x01garbage", "city.osm.pbf", &options),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.starts_with("city.osm.pbf: ") && err.contains("PBF"),
        "{err}"
    );
    let err = crate::common::error_of(
        read_city_bytes(b"type,features\n", "city.geojson", &options),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.contains("not valid JSON") && err.contains("line 1"),
        "{err}"
    );
    let err = crate::common::error_of(
        read_city_bytes(b"type,features\n", "city.txt", &options),
        citypvs::ErrorKind::Input,
    );
    assert!(err.contains("use --format"), "{err}");
}

#[test]
fn forced_format_must_fit_the_content() {
    let geojson = fixture("kotka.geojson");
    for format in [Format::OsmPbf, Format::Cityjson] {
        let err = crate::common::error_of(
            read_city_bytes(&geojson, "k.geojson", &forced(format)),
            citypvs::ErrorKind::Input,
        );
        assert!(err.starts_with("k.geojson: "), "{err}");
    }
    let err = crate::common::error_of(
        read_city_bytes(&fixture("kotka.osm.pbf"), "k.pbf", &forced(Format::Geojson)),
        citypvs::ErrorKind::Input,
    );
    assert!(err.contains("not valid JSON"), "{err}");
    let ok = read_city_bytes(&geojson, "k.data", &forced(Format::Geojson)).unwrap();
    assert_eq!(ok.buildings.len(), 2171);
}
