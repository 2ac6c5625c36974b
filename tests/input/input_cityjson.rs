//! Reading the hand-written CityJSON fixtures (versions 1.1 and 2.0): ids,
//! footprints from GroundSurface or the lowest surface, heights, transform,
//! CRS, and format detection by content.

use std::path::Path;

use citypvs::input::{Format, Frame, InputOptions, read_city, read_city_bytes};
use citypvs::model::{multipolygon_area, multipolygon_bounds};
use glam::DVec2;

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/input")
        .join(name)
}

#[test]
fn both_versions_read_the_same_buildings() {
    for file in ["small-1.1.city.json", "small-2.0.city.json"] {
        let city = read_city(&fixture(file), &InputOptions::default()).unwrap();
        let ids: Vec<&str> = city.buildings.iter().map(|b| b.id.as_str()).collect();
        // "hall" has no geometry of its own (its parts carry it); the tree is not a building.
        assert_eq!(ids, ["hall-a", "hall-b", "hall-c", "house-1"], "{file}");
        assert!(city.report.skipped.is_empty(), "{:?}", city.report.skipped);
        assert_eq!(city.report.features_read, 5);
        assert_eq!(
            city.frame,
            Frame::Metric {
                origin: DVec2::new(490020.0, 6700015.0),
                crs: Some("https://www.opengis.net/def/crs/EPSG/0/3067".into())
            }
        );
        let heights: Vec<f64> = city.buildings.iter().map(|b| b.height).collect();
        // hall-b: its LoD 2.2 gable roof reaches 15 m (the LoD 1 block only 9 m).
        // hall-c: a bridge from 6 m to 9 m above the hall's ground.
        for (h, want) in heights.iter().zip([6.0, 15.0, 9.0, 12.0]) {
            assert!((h - want).abs() < 1e-9, "{file}: {heights:?}");
        }
        let areas: Vec<f64> = city
            .buildings
            .iter()
            .map(|b| multipolygon_area(&b.footprint))
            .collect();
        for (a, want) in areas.iter().zip([200.0, 200.0, 100.0, 100.0]) {
            assert!((a - want).abs() < 1e-6, "{file}: {areas:?}");
        }
        // house-1 (no semantics: its lowest surface) sits at the file's 490000, 6700000.
        let occludes: Vec<bool> = city.buildings.iter().map(|b| b.occludes).collect();
        assert_eq!(occludes, [true, true, false, true], "{file}");
        let house = multipolygon_bounds(&city.buildings[3].footprint);
        assert!(
            (house.min - DVec2::new(-20.0, -15.0)).length() < 1e-9,
            "{house:?}"
        );
        assert!(
            (house.max - DVec2::new(-10.0, -5.0)).length() < 1e-9,
            "{house:?}"
        );
    }
}

#[test]
fn detected_by_content_and_forced_format_is_checked() {
    let bytes = std::fs::read(fixture("small-2.0.city.json")).unwrap();
    let city = read_city_bytes(&bytes, "city.json", &InputOptions::default()).unwrap();
    assert_eq!(city.buildings.len(), 4);
    let forced = InputOptions {
        format: Some(Format::Geojson),
        ..InputOptions::default()
    };
    let err = crate::common::error_of(
        read_city_bytes(&bytes, "city.json", &forced),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.contains("FeatureCollection") && err.contains("CityJSON"),
        "{err}"
    );
}

#[test]
fn bad_vertex_index_names_the_object() {
    let text = std::fs::read_to_string(fixture("small-2.0.city.json")).unwrap();
    let bad = text.replacen(
        "\"vertices\": [",
        "\"vertices\": [[0, 0, 0]], \"unused\": [",
        1,
    );
    let err = crate::common::error_of(
        read_city_bytes(bad.as_bytes(), "bad.city.json", &InputOptions::default()),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.starts_with("bad.city.json: feature \"hall-a\" (index 1)")
            && err.contains("out of range"),
        "{err}"
    );
}
