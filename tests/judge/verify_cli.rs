//! `citypvs verify` end to end: a metric GeoJSON city and hand-written .pvs
//! files; exit 0 on a correct PVS, 1 on a broken one, 2 on the wrong file.

use std::path::Path;
use std::process::Command;

use citypvs::input::{InputOptions, read_city};
use citypvs::pvs::{BakeInfo, PvsData, write_pvs};

/// Offset of the city in its file's metres.
const OFFSET: (f64, f64) = (385_000.0, 6_700_000.0);

/// A street between two rows (id, x0, y0, x1, y1, height), a low house
/// hidden behind the south row, a tower behind the north row, a house at
/// the street's end.
const HOUSES: [(&str, f64, f64, f64, f64, f64); 5] = [
    ("south", 0.0, -20.0, 100.0, -10.0, 10.0),
    ("north", 0.0, 10.0, 100.0, 20.0, 10.0),
    ("hidden", 40.0, -40.0, 60.0, -30.0, 6.0),
    ("tower", 40.0, 30.0, 60.0, 40.0, 80.0),
    ("end", 120.0, -10.0, 130.0, 10.0, 10.0),
];

fn city_geojson() -> String {
    let features: Vec<String> = HOUSES
        .iter()
        .map(|&(id, x0, y0, x1, y1, h)| {
            let (x0, y0, x1, y1) = (x0 + OFFSET.0, y0 + OFFSET.1, x1 + OFFSET.0, y1 + OFFSET.1);
            format!(
                r#"{{"type":"Feature","id":"{id}","properties":{{"building":"yes","height":{h}}},"geometry":{{"type":"Polygon","coordinates":[[[{x0},{y0}],[{x1},{y0}],[{x1},{y1}],[{x0},{y1}],[{x0},{y0}]]]}}}}"#
            )
        })
        .collect();
    format!(
        r#"{{"type":"FeatureCollection","features":[{}]}}"#,
        features.join(",")
    )
}

/// Four street cells (in the file's metres, shifted to local by the city's
/// frame) and their visible sets by id.
fn pvs(city_path: &Path, visible: [&[&str]; 4], ids: &[&str]) -> PvsData {
    let city = read_city(
        city_path,
        &InputOptions {
            metric: true,
            ..InputOptions::default()
        },
    )
    .expect("the test city reads");
    let q = |x: f64, y: f64| {
        citypvs::pvs::mesh::snap(city.frame.to_local(x + OFFSET.0, y + OFFSET.1)).unwrap()
    };
    let cells = vec![
        [q(0.0, -10.0), q(50.0, -10.0), q(0.0, 10.0)],
        [q(50.0, -10.0), q(50.0, 10.0), q(0.0, 10.0)],
        [q(50.0, -10.0), q(100.0, -10.0), q(50.0, 10.0)],
        [q(100.0, -10.0), q(100.0, 10.0), q(50.0, 10.0)],
    ];
    PvsData {
        object_prints: Vec::new(),
        info: BakeInfo {
            numbers: citypvs::BakeNumbers {
                eps: 0.25,
                eye_height: 1.7,
                pixel: 0.34,
                max_cell_edge: 60.0,
                margin: 10.0,
                near_field: 48.0,
                min_gap: 0.0,
            },
            frame: city.frame.clone(),
            source_hash: city.source_hash,
            region_hash: [0; 32],
            tool_version: "citypvs test".into(),
        },
        object_ids: ids.iter().map(|s| s.to_string()).collect(),
        cells,
        visible: visible
            .iter()
            .map(|set| {
                let mut v: Vec<u32> = set
                    .iter()
                    .map(|id| ids.iter().position(|x| x == id).unwrap() as u32)
                    .collect();
                v.sort();
                v
            })
            .collect(),
    }
}

fn run(args: &[&Path], extra: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .arg("verify")
        .args(args)
        // Hand-written cells, not the ones `bake` would make for the city.
        .args(["--metric", "--samples", "24", "--any-cells"])
        .args(extra)
        .output()
        .expect("citypvs runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn verify_passes_a_correct_pvs_and_fails_a_broken_one() {
    let dir = tempfile::tempdir().unwrap();
    let city = dir.path().join("street.geojson");
    std::fs::write(&city, city_geojson()).unwrap();
    // Object order differs from the city's on purpose: ids are matched by name.
    let ids = ["tower", "end", "south", "north", "hidden"];
    let seen: &[&str] = &["south", "north", "tower", "end"];

    let good = dir.path().join("good.pvs");
    write_pvs(&good, &pvs(&city, [seen; 4], &ids)).unwrap();
    let (code, out, err) = run(&[&city, &good], &[]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(
        out.contains("violations     0") && out.contains("PASS"),
        "{out}"
    );

    // A superset also passes; its tightness shows it.
    let loose = dir.path().join("loose.pvs");
    let all: &[&str] = &ids;
    write_pvs(&loose, &pvs(&city, [all; 4], &ids)).unwrap();
    let (code, out, _) = run(&[&city, &loose], &["--json"]);
    assert_eq!(code, 0);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["passed"], true);
    assert_eq!(v["source_matches"], true);
    assert!((v["mean_tightness"].as_f64().unwrap() - 1.25).abs() < 1e-12);
    assert_eq!(v["cells_checked"], 4);
    assert_eq!(v["viewpoints"], 4 * 24);

    // Cell 3 leaves out the tower: exit 1, and the violation names it.
    let broken = dir.path().join("broken.pvs");
    let no_tower: &[&str] = &["south", "north", "end"];
    write_pvs(&broken, &pvs(&city, [seen, seen, seen, no_tower], &ids)).unwrap();
    let (code, out, _) = run(&[&city, &broken], &["--json"]);
    assert_eq!(code, 1, "{out}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["passed"], false);
    let violations = v["violations"].as_array().unwrap();
    assert_eq!(violations.len(), 1, "{out}");
    assert_eq!(violations[0]["cell"], 3);
    assert_eq!(violations[0]["building"], "tower");
    assert_eq!(violations[0]["witness"][2], 80.0);
    // In the file's own metres the witness is on the tower's south wall.
    let input_y = violations[0]["witness_input"][1].as_f64().unwrap();
    assert!((input_y - (OFFSET.1 + 30.0)).abs() < 1e-6, "{out}");
    let (code, out, _) = run(&[&city, &broken], &["--all", "--seed", "9"]);
    assert_eq!(code, 1);
    assert!(
        out.contains("cell 3 misses tower") && out.contains("FAIL"),
        "{out}"
    );

    // A PVS of another city: exit 2 with a message naming the object.
    let wrong = dir.path().join("wrong.pvs");
    let other_ids = ["tower", "end", "south", "north", "elsewhere"];
    write_pvs(&wrong, &pvs(&city, [&["south"]; 4], &other_ids)).unwrap();
    let (code, _, err) = run(&[&city, &wrong], &[]);
    assert_eq!(code, 2);
    assert!(err.contains("elsewhere") && err.contains("wrong"), "{err}");
}

/// `--region` only serves the check that `--any-cells` skips: the two
/// together are refused before anything is read.
#[test]
fn region_with_any_cells_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = crate::common::citypvs(
        dir.path(),
        &[
            "verify",
            "city.geojson",
            "city.pvs",
            "--any-cells",
            "--region",
            "region.geojson",
        ],
    );
    let err = crate::common::stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--region") && err.contains("--any-cells"),
        "{err}"
    );
}
