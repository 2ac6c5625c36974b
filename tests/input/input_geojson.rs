//! Reading GeoJSON cities through the library: the generated city, the
//! Kotka fixture, heights, ids, coordinates, repairs, --strict and regions.

use std::path::Path;

use citypvs::generate::{GenerateParams, generate_buildings, generate_geojson};
use citypvs::input::{Frame, InputOptions, read_city, read_city_bytes, read_region};
use citypvs::model::{multipolygon_area, polygon_area, ring_signed_area2};
use glam::DVec2;
use sha2::{Digest, Sha256};

fn read(text: &str) -> citypvs::Result<citypvs::input::City> {
    read_city_bytes(text.as_bytes(), "test.geojson", &InputOptions::default())
}

fn read_with(text: &str, options: &InputOptions) -> citypvs::Result<citypvs::input::City> {
    read_city_bytes(text.as_bytes(), "test.geojson", options)
}

/// A FeatureCollection from feature bodies, each `"id":..,"properties":..,"geometry":..`.
fn collection(features: &[String]) -> String {
    let body: Vec<String> = features
        .iter()
        .map(|f| format!("{{\"type\":\"Feature\",{f}}}"))
        .collect();
    format!(
        "{{\"type\":\"FeatureCollection\",\"features\":[{}]}}",
        body.join(",")
    )
}

/// A closed square ring of side `s` degrees/metres at (x, y), counter-clockwise.
fn square(x: f64, y: f64, s: f64) -> String {
    format!(
        "[[{x},{y}],[{},{y}],[{},{}],[{x},{}],[{x},{y}]]",
        x + s,
        x + s,
        y + s,
        y + s
    )
}

fn polygon_feature(id: &str, props: &str, ring: &str) -> String {
    format!(
        "\"id\":{id},\"properties\":{{{props}}},\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[{ring}]}}"
    )
}

/// Every output footprint follows the model's conventions.
fn assert_model_conventions(city: &citypvs::input::City) {
    for b in &city.buildings {
        assert!(b.height > 0.0 && b.height <= 1000.0, "{}", b.id);
        assert!(!b.footprint.is_empty(), "{}", b.id);
        for p in &b.footprint {
            assert!(
                ring_signed_area2(&p.exterior) > 0.0,
                "{} exterior not CCW",
                b.id
            );
            assert_ne!(
                p.exterior.first(),
                p.exterior.last(),
                "{} ring closed",
                b.id
            );
            assert!(p.exterior.len() >= 3);
            for h in &p.holes {
                assert!(ring_signed_area2(h) < 0.0, "{} hole not CW", b.id);
            }
            assert!(polygon_area(p) > 0.0);
        }
    }
}

#[test]
fn generated_city_reads_without_repairs() {
    // The embedded default city of `citypvs bake`.
    let params = GenerateParams {
        buildings: citypvs::cli::bake::DEFAULT_CITY_BUILDINGS,
        seed: citypvs::cli::bake::DEFAULT_CITY_SEED,
    };
    let text = generate_geojson(&params);
    let expected = generate_buildings(&params);
    let city = read(&text).unwrap();
    assert_eq!(city.buildings.len(), expected.len());
    assert!(
        city.report.repaired.is_empty(),
        "{:?}",
        &city.report.repaired[..3.min(city.report.repaired.len())]
    );
    assert!(city.report.skipped.is_empty());
    assert_model_conventions(&city);
    // Same ids and heights, and the same footprint area (7-decimal degrees
    // are about 1 cm, so areas agree to well under a square metre).
    for (b, g) in city.buildings.iter().zip(&expected) {
        assert_eq!(b.id, g.id);
        assert!((b.height - (g.height * 10.0).round() / 10.0).abs() < 1e-9);
        let area = multipolygon_area(&b.footprint);
        let want = polygon_area(&g.footprint);
        assert!(
            (area - want).abs() < 0.01 * want.sqrt() * 4.0,
            "{} {area} {want}",
            b.id
        );
    }
    let Frame::LonLat { lon0, lat0 } = city.frame else {
        panic!("generated city must be lon/lat")
    };
    // The origin is the centre of the buildings, near the generator's origin.
    assert!((lon0 - citypvs::generate::ORIGIN_LON).abs() < 0.01);
    assert!((lat0 - citypvs::generate::ORIGIN_LAT).abs() < 0.01);
    assert_eq!(
        city.source_hash,
        <[u8; 32]>::from(Sha256::digest(text.as_bytes()))
    );
}

#[test]
fn kotka_geojson_reads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kotka.geojson");
    let city = read_city(&path, &InputOptions::default()).unwrap();
    assert_eq!(city.report.features_read, 2171);
    assert_eq!(
        city.buildings.len() + city.report.skipped.len(),
        2171,
        "{:?}",
        city.report.skipped
    );
    assert!(city.buildings.len() > 2150);
    eprintln!(
        "kotka.geojson: {} buildings, {} repaired, {} skipped; first repairs: {:?}",
        city.buildings.len(),
        city.report.repaired.len(),
        city.report.skipped.len(),
        &city.report.repaired[..5.min(city.report.repaired.len())]
    );
    assert_model_conventions(&city);
    let levels = city.buildings.iter().filter(|b| b.height == 3.0).count();
    assert_eq!(levels, 10);
    // The whole extract is about 2.2 km across, around the local origin.
    for b in &city.buildings {
        for p in &b.footprint[0].exterior {
            assert!(p.x.abs() < 2000.0 && p.y.abs() < 2000.0, "{} at {p}", b.id);
        }
    }
}

#[test]
fn heights_from_numbers_text_levels_and_default() {
    let features = [
        polygon_feature("\"a\"", "\"height\":12", &square(25.0, 60.0, 0.0001)),
        polygon_feature(
            "\"b\"",
            "\"height\":\"12.5 m\"",
            &square(25.001, 60.0, 0.0001),
        ),
        polygon_feature("\"c\"", "\"height\":\"7\"", &square(25.002, 60.0, 0.0001)),
        polygon_feature(
            "\"d\"",
            "\"building:levels\":\"4\"",
            &square(25.003, 60.0, 0.0001),
        ),
        polygon_feature("\"e\"", "\"levels\":2", &square(25.004, 60.0, 0.0001)),
        polygon_feature("\"f\"", "\"name\":\"x\"", &square(25.005, 60.0, 0.0001)),
        polygon_feature(
            "\"g\"",
            "\"height\":\"40 ft\"",
            &square(25.006, 60.0, 0.0001),
        ),
    ];
    let options = InputOptions {
        default_height: 5.5,
        ..InputOptions::default()
    };
    let city = read_with(&collection(&features), &options).unwrap();
    let heights: Vec<f64> = city.buildings.iter().map(|b| b.height).collect();
    let want = [12.0, 12.5, 7.0, 12.0, 6.0, 5.5, 40.0 * 0.3048];
    for (h, w) in heights.iter().zip(want) {
        assert!((h - w).abs() < 1e-9, "{heights:?}");
    }
    assert!(city.buildings.iter().all(|b| b.occludes));

    // A lifted part (min_height > 0) is an object but not an occluder.
    let lifted = [
        polygon_feature(
            "\"bridge\"",
            "\"height\":14,\"min_height\":\"8 m\"",
            &square(25.0, 60.0, 0.0001),
        ),
        polygon_feature(
            "\"ground\"",
            "\"height\":14,\"min_height\":0",
            &square(25.001, 60.0, 0.0001),
        ),
    ];
    let city = read(&collection(&lifted)).unwrap();
    let occludes: Vec<(f64, bool)> = city
        .buildings
        .iter()
        .map(|b| (b.height, b.occludes))
        .collect();
    assert_eq!(occludes, [(14.0, false), (14.0, true)]);
}

#[test]
fn ids_from_feature_property_or_index() {
    let features = [
        polygon_feature("\"x1\"", "\"id\":\"ignored\"", &square(25.0, 60.0, 0.0001)),
        polygon_feature("17", "", &square(25.001, 60.0, 0.0001)),
        polygon_feature("null", "\"id\":\"p3\"", &square(25.002, 60.0, 0.0001)),
        polygon_feature("null", "", &square(25.003, 60.0, 0.0001)),
    ];
    let city = read(&collection(&features)).unwrap();
    let ids: Vec<&str> = city.buildings.iter().map(|b| b.id.as_str()).collect();
    assert_eq!(ids, ["x1", "17", "p3", "3"]);
}

#[test]
fn metric_option_and_legacy_crs_keep_metres() {
    let features = [
        polygon_feature("\"a\"", "", &square(500000.0, 6700000.0, 10.0)),
        polygon_feature("\"b\"", "", &square(500020.0, 6700000.0, 10.0)),
    ];
    let text = collection(&features);
    let metric = InputOptions {
        metric: true,
        ..InputOptions::default()
    };
    let city = read_with(&text, &metric).unwrap();
    let Frame::Metric { origin, crs } = &city.frame else {
        panic!("{:?}", city.frame)
    };
    assert_eq!(*origin, DVec2::new(500015.0, 6700005.0));
    assert_eq!(*crs, None);
    let a = &city.buildings[0].footprint[0].exterior;
    assert_eq!(a[0], DVec2::new(-15.0, -5.0));
    assert!((multipolygon_area(&city.buildings[1].footprint) - 100.0).abs() < 1e-9);

    let with_crs = text.replacen(
        "{\"type\":\"FeatureCollection\",",
        "{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":{\"name\":\"urn:ogc:def:crs:EPSG::3067\"}},",
        1,
    );
    let city = read(&with_crs).unwrap();
    assert_eq!(
        city.frame,
        Frame::Metric {
            origin: DVec2::new(500015.0, 6700005.0),
            crs: Some("urn:ogc:def:crs:EPSG::3067".into())
        }
    );
}

#[test]
fn lon_lat_origin_is_the_buildings_centre_and_scale_is_metres() {
    // Two squares 0.001 degrees of longitude apart at 60 N: their bounding
    // box centre is the origin, and a degree of latitude is about 111.4 km.
    let features = [
        polygon_feature("\"a\"", "", &square(25.0, 60.0, 0.0001)),
        polygon_feature("\"b\"", "", &square(25.0009, 60.0, 0.0001)),
    ];
    let city = read(&collection(&features)).unwrap();
    let Frame::LonLat { lon0, lat0 } = city.frame else {
        panic!("{:?}", city.frame)
    };
    assert!((lon0 - 25.0005).abs() < 1e-12 && (lat0 - 60.00005).abs() < 1e-12);
    let a = &city.buildings[0].footprint[0].exterior;
    let height = a[2].y - a[1].y;
    assert!((height - 11.14).abs() < 0.02, "{height}");
    let centre_x = (a[0].x + city.buildings[1].footprint[0].exterior[1].x) / 2.0;
    assert!(centre_x.abs() < 1e-6, "{centre_x}");
}

#[test]
fn repairs_are_counted_and_named() {
    let unclosed = "[[25.0,60.0],[25.0001,60.0],[25.0001,60.0001],[25.0,60.0001]]";
    let clockwise =
        "[[25.001,60.0],[25.001,60.0001],[25.0011,60.0001],[25.0011,60.0],[25.001,60.0]]";
    let bowtie = "[[25.002,60.0],[25.0021,60.0001],[25.0021,60.0],[25.002,60.0001],[25.002,60.0]]";
    let overlapping = format!(
        "\"id\":\"m\",\"properties\":{{}},\"geometry\":{{\"type\":\"MultiPolygon\",\"coordinates\":[[{}],[{}]]}}",
        square(25.003, 60.0, 0.0001),
        square(25.00305, 60.00005, 0.0001)
    );
    let features = [
        polygon_feature("\"u\"", "", unclosed),
        polygon_feature("\"c\"", "", clockwise),
        polygon_feature("\"t\"", "", bowtie),
        overlapping,
        polygon_feature("\"ok\"", "", &square(25.004, 60.0, 0.0001)),
        polygon_feature("\"flat\"", "", "[[25.005,60.0],[25.0051,60.0],[25.0052,60.0],[25.005,60.0]]"),
        "\"id\":\"pt\",\"properties\":{},\"geometry\":{\"type\":\"Point\",\"coordinates\":[25.0,60.0]}".to_string(),
    ];
    let text = collection(&features);
    let city = read(&text).unwrap();
    assert_model_conventions(&city);
    let repaired: Vec<&str> = city
        .report
        .repaired
        .iter()
        .map(|w| w.feature.as_str())
        .collect();
    assert_eq!(repaired, ["u", "c", "t", "m"]);
    let skipped: Vec<&str> = city
        .report
        .skipped
        .iter()
        .map(|w| w.feature.as_str())
        .collect();
    assert_eq!(skipped, ["pt", "flat"]);
    assert_eq!(city.report.features_read, 7);
    assert_eq!(city.report.buildings, 5);
    assert!(city.report.repaired[0].message.contains("not closed"));
    assert!(city.report.repaired[1].message.contains("winding"));
    assert!(city.report.repaired[2].message.contains("BooleanOps"));
    // The bowtie keeps both lobes; the overlapping pair becomes one polygon.
    let by_id = |id: &str| city.buildings.iter().find(|b| b.id == id).unwrap();
    assert_eq!(by_id("t").footprint.len(), 2);
    assert_eq!(by_id("m").footprint.len(), 1);
    let one = multipolygon_area(&by_id("ok").footprint);
    let union = multipolygon_area(&by_id("m").footprint);
    assert!((union / one - 1.75).abs() < 0.01, "{union} {one}");

    let strict = InputOptions {
        strict: true,
        ..InputOptions::default()
    };
    let err = crate::common::error_of(read_with(&text, &strict), citypvs::ErrorKind::Input);
    assert!(err.contains("--strict") && err.contains("pt"), "{err}");
}

#[test]
fn region_files_in_the_city_frame() {
    let dir = tempfile::tempdir().unwrap();
    let frame = Frame::Metric {
        origin: DVec2::new(1000.0, 2000.0),
        crs: None,
    };
    let feature = dir.path().join("region.geojson");
    std::fs::write(
        &feature,
        "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[1000,2000],[1000,2100],[1100,2100],[1100,2000],[1000,2000]]]}}",
    )
    .unwrap();
    let region = read_region(&feature, &frame).unwrap();
    assert!(ring_signed_area2(&region.exterior) > 0.0);
    assert!((polygon_area(&region) - 10000.0).abs() < 1e-9);
    assert!(region.exterior.contains(&DVec2::new(100.0, 100.0)));

    let two = dir.path().join("two.geojson");
    std::fs::write(
        &two,
        format!("{{\"type\":\"FeatureCollection\",\"features\":[{{\"type\":\"Feature\",\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[{}]}}}},{{\"type\":\"Feature\",\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[{}]}}}}]}}", square(0.0, 0.0, 1.0), square(5.0, 0.0, 1.0)),
    )
    .unwrap();
    let err = crate::common::error_of(read_region(&two, &frame), citypvs::ErrorKind::Input);
    assert!(
        err.contains("two.geojson") && err.contains("one polygon"),
        "{err}"
    );
}
