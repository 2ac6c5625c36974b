//! The Kotka OSM PBF extract and its GeoJSON conversion give the same
//! buildings: same ids, heights within 1 cm, footprints within 1 cm. Also a
//! truncated PBF fails with a clear message.

use std::collections::BTreeMap;
use std::path::Path;

use citypvs::input::{Format, InputOptions, read_city, read_city_bytes};
use citypvs::model::{Building, distance_to_segment, polygon_edges};
use glam::DVec2;

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// Largest distance from a vertex of `a` to the boundary of `b`.
fn one_sided_distance(a: &Building, b: &Building) -> f64 {
    let vertices: Vec<DVec2> = a
        .footprint
        .iter()
        .flat_map(|p| {
            std::iter::once(&p.exterior)
                .chain(&p.holes)
                .flatten()
                .copied()
        })
        .collect();
    vertices
        .iter()
        .map(|&v| {
            b.footprint
                .iter()
                .flat_map(polygon_edges)
                .map(|(s, t)| distance_to_segment(v, s, t))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn kotka_pbf_matches_its_geojson() {
    let options = InputOptions::default();
    let pbf = read_city(&fixture("kotka.osm.pbf"), &options).unwrap();
    let json = read_city(&fixture("kotka.geojson"), &options).unwrap();
    eprintln!(
        "pbf: {} buildings, {} repaired, {} skipped {:?}",
        pbf.buildings.len(),
        pbf.report.repaired.len(),
        pbf.report.skipped.len(),
        &pbf.report.skipped[..pbf.report.skipped.len().min(5)]
    );
    let by_id = |c: &citypvs::input::City| -> BTreeMap<String, Building> {
        c.buildings
            .iter()
            .map(|b| (b.id.clone(), b.clone()))
            .collect()
    };
    let (p, j) = (by_id(&pbf), by_id(&json));
    let only_pbf: Vec<&String> = p.keys().filter(|k| !j.contains_key(*k)).collect();
    let only_json: Vec<&String> = j.keys().filter(|k| !p.contains_key(*k)).collect();
    assert!(
        only_pbf.is_empty() && only_json.is_empty(),
        "ids differ: only in PBF {} {:?}, only in GeoJSON {} {:?}",
        only_pbf.len(),
        &only_pbf[..only_pbf.len().min(10)],
        only_json.len(),
        &only_json[..only_json.len().min(10)]
    );
    assert_eq!(pbf.buildings.len(), 2171);
    // Both are centred on the same buildings, so local frames agree.
    assert_eq!(pbf.frame, json.frame);
    let mut worst: f64 = 0.0;
    for (id, a) in &p {
        let b = &j[id];
        assert!(
            (a.height - b.height).abs() < 0.01,
            "{id}: {} vs {}",
            a.height,
            b.height
        );
        assert_eq!(a.occludes, b.occludes, "{id}");
        let d = one_sided_distance(a, b).max(one_sided_distance(b, a));
        assert!(d < 0.01, "{id}: footprints differ by {d} m");
        worst = worst.max(d);
    }
    eprintln!("largest footprint difference: {worst:e} m");
}

#[test]
fn truncated_pbf_is_a_clear_error() {
    let bytes = std::fs::read(fixture("kotka.osm.pbf")).unwrap();
    let cut = &bytes[..bytes.len() / 2];
    let err = read_city_bytes(cut, "cut.osm.pbf", &InputOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("cut.osm.pbf: ") && err.contains("truncated"),
        "{err}"
    );
    // Forcing the format on a GeoJSON file gives a PBF error, not a panic.
    let json = std::fs::read(fixture("kotka.geojson")).unwrap();
    let forced = InputOptions {
        format: Some(Format::OsmPbf),
        ..InputOptions::default()
    };
    let err = read_city_bytes(&json, "k.geojson", &forced)
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("k.geojson: "), "{err}");
}
