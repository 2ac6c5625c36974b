//! Hostile and careless input refused (or repaired with a named warning)
//! at reading time: absurd coordinates and extents, CityJSON versions,
//! missing transforms, parent cycles, `min_height` above `height`, and
//! absurd `--threads`.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use citypvs::input::{InputOptions, read_city_bytes};
use serde_json::{Value, json};

fn metric() -> InputOptions {
    InputOptions {
        metric: true,
        ..InputOptions::default()
    }
}

fn square(id: &str, x: f64, y: f64, size: f64, props: Value) -> Value {
    let mut properties = json!({ "id": id, "height": 10.0 });
    for (k, v) in props.as_object().unwrap() {
        properties[k] = v.clone();
    }
    json!({
        "type": "Feature",
        "properties": properties,
        "geometry": {"type": "Polygon", "coordinates": [[
            [x, y], [x + size, y], [x + size, y + size], [x, y + size], [x, y]
        ]]}
    })
}

fn collection(features: Vec<Value>) -> Vec<u8> {
    serde_json::to_vec(&json!({"type": "FeatureCollection", "features": features})).unwrap()
}

fn error_of(bytes: &[u8], options: &InputOptions) -> String {
    match read_city_bytes(bytes, "city.geojson", options) {
        Ok(city) => panic!("accepted: {} buildings", city.buildings.len()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_metric_vertex_at_1e15_is_refused_naming_the_feature_and_the_coordinate() {
    let mut far = square("far", 0.0, 40.0, 10.0, json!({}));
    far["geometry"]["coordinates"][0][1][0] = json!(1e15);
    let bytes = collection(vec![square("a", 0.0, 0.0, 10.0, json!({})), far]);
    let e = error_of(&bytes, &metric());
    assert!(
        e.starts_with("city.geojson: feature \"far\" (index 1)"),
        "{e}"
    );
    assert!(e.contains("1000000000000000"), "{e}");
    assert!(e.contains("absurd"), "{e}");
}

#[test]
fn a_city_wider_than_the_limit_is_refused_naming_the_outlying_feature() {
    // Ordinary coordinates each, but one building 300 km from the rest.
    let mut features: Vec<Value> = (0..5)
        .map(|k| {
            square(
                &format!("b{k}"),
                3.0e5 + 20.0 * k as f64,
                6.0e6,
                10.0,
                json!({}),
            )
        })
        .collect();
    features.push(square("typo", 6.0e5, 6.0e6, 10.0, json!({})));
    let e = error_of(&collection(features), &metric());
    assert!(e.contains("feature \"typo\" (index 5)"), "{e}");
    assert!(
        e.contains("(600010, 6000010)") && e.contains("100 km"),
        "{e}"
    );
    // 60 km across is a city.
    let features = vec![
        square("west", 3.0e5, 6.0e6, 10.0, json!({})),
        square("east", 3.6e5, 6.0e6, 10.0, json!({})),
    ];
    assert!(read_city_bytes(&collection(features), "c", &metric()).is_ok());
}

#[test]
fn a_lon_lat_building_on_the_far_side_of_the_world_is_refused() {
    let near = square("kotka", 26.94, 60.47, 0.0002, json!({}));
    let far = square("fiji", 178.0, -17.7, 0.0002, json!({}));
    let e = error_of(
        &collection(vec![near.clone(), far]),
        &InputOptions::default(),
    );
    assert!(
        e.contains("feature \"fiji\"") || e.contains("feature \"kotka\""),
        "{e}"
    );
    assert!(e.contains("km") || e.contains("cannot be projected"), "{e}");
}

#[test]
fn a_region_far_outside_the_city_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let city = dir.path().join("city.geojson");
    std::fs::write(
        &city,
        collection(vec![
            square("a", 0.0, 0.0, 10.0, json!({})),
            square("b", 30.0, 0.0, 10.0, json!({})),
        ]),
    )
    .unwrap();
    let region = dir.path().join("region.geojson");
    std::fs::write(
        &region,
        serde_json::to_vec(&json!({"type": "Polygon", "coordinates": [[
            [-50.0, -50.0], [1e9, -50.0], [1e9, 50.0], [-50.0, 50.0], [-50.0, -50.0]
        ]]}))
        .unwrap(),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .args(["prepare", "--metric", "--region"])
        .args([&region, &city])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("region") && e.contains("1000000000"), "{e}");
}

#[test]
fn min_height_above_height_is_kept_as_a_non_occluding_part_with_a_named_warning() {
    let bytes = collection(vec![
        square("ok", 0.0, 0.0, 10.0, json!({})),
        square("upside-down", 30.0, 0.0, 10.0, json!({"min_height": 20.0})),
    ]);
    let city = read_city_bytes(&bytes, "c", &metric()).unwrap();
    let b = city
        .buildings
        .iter()
        .find(|b| b.id == "upside-down")
        .unwrap();
    assert!(!b.occludes);
    assert_eq!(city.report.repaired.len(), 1, "{:?}", city.report.repaired);
    let w = &city.report.repaired[0];
    assert_eq!(w.feature, "upside-down");
    assert!(
        w.message
            .contains("min_height 20 m is not below height 10 m"),
        "{w:?}"
    );
    let strict = InputOptions {
        strict: true,
        ..metric()
    };
    let e = error_of(&bytes, &strict);
    assert!(
        e.contains("\"upside-down\"") && e.contains("min_height"),
        "{e}"
    );
}

fn small_cityjson() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/input/small-1.1.city.json");
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

fn read_cityjson(doc: &Value) -> Result<usize, String> {
    read_city_bytes(
        &serde_json::to_vec(doc).unwrap(),
        "c.city.json",
        &InputOptions::default(),
    )
    .map(|c| c.buildings.len())
    .map_err(|e| {
        assert_eq!(e.kind(), &citypvs::ErrorKind::Input, "{e}");
        e.to_string()
    })
}

#[test]
fn cityjson_versions_are_accepted_exactly_not_by_prefix() {
    for good in ["1.1", "1.1.3", "2.0", "2.0.1", "1.0", "1.0.2"] {
        let mut doc = small_cityjson();
        doc["version"] = json!(good);
        assert_eq!(read_cityjson(&doc), Ok(4), "version {good}");
    }
    for bad in [
        "1.19",
        "2.0-garbage",
        "2.01",
        "1.1.",
        "1.1.x",
        "3.0",
        "",
        "2",
    ] {
        let mut doc = small_cityjson();
        doc["version"] = json!(bad);
        let e = read_cityjson(&doc).unwrap_err();
        assert!(
            e.contains(&format!("version \"{bad}\" is not supported"))
                && e.contains("1.0, 1.1 and 2.0"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn a_numeric_cityjson_version_is_named_as_a_number() {
    let mut doc = small_cityjson();
    doc["version"] = json!(1.1);
    let e = read_cityjson(&doc).unwrap_err();
    assert!(e.contains("the number 1.1") && e.contains("string"), "{e}");
    assert!(!e.contains("(none)"), "{e}");
}

#[test]
fn a_missing_transform_is_named_in_1_1_and_2_0_and_optional_in_1_0() {
    for version in ["1.1", "2.0"] {
        let mut doc = small_cityjson();
        doc["version"] = json!(version);
        doc.as_object_mut().unwrap().remove("transform");
        let e = read_cityjson(&doc).unwrap_err();
        assert!(e.contains("has no \"transform\""), "{version}: {e}");
        assert!(!e.contains("absurd"), "{e}");
    }
    // CityJSON 1.0 vertices may be plain metres: scale them here instead.
    let mut doc = small_cityjson();
    doc["version"] = json!("1.0");
    let t = doc.as_object_mut().unwrap().remove("transform").unwrap();
    let (s, o) = (&t["scale"], &t["translate"]);
    for v in doc["vertices"].as_array_mut().unwrap() {
        for k in 0..3 {
            v[k] = json!(v[k].as_f64().unwrap() * s[k].as_f64().unwrap() + o[k].as_f64().unwrap());
        }
    }
    assert_eq!(read_cityjson(&doc), Ok(4));
}

#[test]
fn cityjson_parent_cycles_are_refused_with_the_ids() {
    let mut doc = small_cityjson();
    let objects = doc["CityObjects"].as_object_mut().unwrap();
    objects["hall"]["parents"] = json!(["hall-a"]);
    let e = read_cityjson(&doc).unwrap_err();
    assert!(e.contains("cycle"), "{e}");
    assert!(e.contains("\"hall-a\"") && e.contains("\"hall\""), "{e}");
    // An object that is its own parent.
    let mut doc = small_cityjson();
    doc["CityObjects"]["house-1"]["parents"] = json!(["house-1"]);
    let e = read_cityjson(&doc).unwrap_err();
    assert!(e.contains("\"house-1\" -> \"house-1\""), "{e}");
}

#[test]
fn an_absurd_number_of_verify_samples_is_refused_at_once() {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .args([
            "verify",
            "no-such-city.geojson",
            "no-such.pvs",
            "--samples",
            "1000000000",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("--samples must be between 1 and 100000"), "{e}");
}

#[test]
fn bench_refuses_absurd_city_sizes_at_once() {
    for n in ["0", "1000000000000"] {
        let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
            .args(["bench", "--buildings", n])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(e.contains("--buildings must be between 1 and"), "{n}: {e}");
    }
}

#[test]
fn absurd_thread_counts_are_refused_at_once() {
    for (command, threads) in [("bake", "10000"), ("bake", "0"), ("verify", "100000")] {
        let t = Instant::now();
        let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
            .args([command, "no-such-city.geojson", "--threads", threads])
            .args(if command == "verify" {
                &["no-such.pvs"][..]
            } else {
                &[][..]
            })
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2));
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(
            e.contains("--threads must be between 1 and") && e.contains(&format!("got {threads}")),
            "{command} --threads {threads}: {e}"
        );
        // Refused before any thread is started (which took about a minute for 10,000).
        assert!(t.elapsed().as_secs() < 20);
    }
}
