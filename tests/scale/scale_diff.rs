//! `citypvs diff`: cells added and removed (matched by triangle), buildings
//! gained and lost per common cell (matched by id), JSON, and the exit
//! status (0 equal, 1 different, 2 error).

use std::path::Path;
use std::process::Command;

use citypvs::input::Frame;
use citypvs::pvs::{BakeInfo, PvsData, write_pvs};
use glam::DVec2;

fn tri(x: f64) -> [DVec2; 3] {
    [
        DVec2::new(x, 0.0),
        DVec2::new(x + 1.0, 0.0),
        DVec2::new(x, 1.0),
    ]
}

fn data(ids: &[&str], cells: &[f64], visible: Vec<Vec<u32>>) -> PvsData {
    PvsData {
        object_prints: Vec::new(),
        info: BakeInfo {
            numbers: citypvs::BakeNumbers {
                eps: 1.0,
                eye_height: 1.7,
                pixel: 1.4,
                max_cell_edge: 30.0,
                margin: 50.0,
                near_field: 48.0,
                min_gap: 0.0,
            },
            frame: Frame::Metric {
                origin: DVec2::ZERO,
                crs: None,
            },
            source_hash: [1; 32],
            region_hash: [0; 32],
            tool_version: "test".into(),
        },
        object_ids: ids.iter().map(|s| s.to_string()).collect(),
        cells: cells.iter().map(|&x| tri(x)).collect(),
        visible,
    }
}

fn diff(dir: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .arg("diff")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn diff_lists_cells_added_removed_and_buildings_gained_and_lost_by_id() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Old: cells at x = 0, 10, 20; objects a b c.
    let old = data(
        &["a", "b", "c"],
        &[0.0, 10.0, 20.0],
        vec![vec![0, 1], vec![2], vec![0, 1, 2]],
    );
    // New: object b removed, d added (indices move), cell 10 gone, cell 30 new,
    // cell 0 loses b, cell 20 loses b and gains d.
    let new = data(
        &["d", "a", "c"],
        &[20.0, 0.0, 30.0],
        vec![vec![0, 1, 2], vec![1], vec![2]],
    );
    write_pvs(&d.join("old.pvs"), &old).unwrap();
    write_pvs(&d.join("new.pvs"), &new).unwrap();
    // The same sets with the objects in another order: equal.
    let same = data(
        &["c", "b", "a"],
        &[20.0, 0.0, 10.0],
        vec![vec![0, 1, 2], vec![1, 2], vec![0]],
    );
    write_pvs(&d.join("same.pvs"), &same).unwrap();

    let (code, stdout, stderr) = diff(d, &["old.pvs", "new.pvs", "--json"]);
    assert_eq!(code, Some(1), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["equal"], false);
    assert_eq!(v["cells_removed"], serde_json::json!([1]));
    assert_eq!(v["cells_added"], serde_json::json!([2]));
    assert_eq!(v["common_cells"], 2);
    assert_eq!(v["objects_removed"], serde_json::json!(["b"]));
    assert_eq!(v["objects_added"], serde_json::json!(["d"]));
    assert_eq!(
        v["changed"],
        serde_json::json!([
            {"cell_a": 0, "cell_b": 1, "gained": [], "lost": ["b"]},
            {"cell_a": 2, "cell_b": 0, "gained": ["d"], "lost": ["b"]},
        ])
    );
    let (code, stdout, _) = diff(d, &["old.pvs", "new.pvs"]);
    assert_eq!(code, Some(1));
    assert!(
        stdout.contains("1 cells removed, 1 added, 2 of 2 common cells changed"),
        "{stdout}"
    );
    assert!(stdout.contains("cell    2 -> 0: +d -b"), "{stdout}");

    let (code, stdout, stderr) = diff(d, &["old.pvs", "same.pvs", "--json"]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert_eq!(
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap()["equal"],
        true
    );
    let (code, _, _) = diff(d, &["old.pvs", "old.pvs"]);
    assert_eq!(code, Some(0));

    std::fs::write(d.join("bad.pvs"), b"CITYPVS\0 short").unwrap();
    for args in [["old.pvs", "missing.pvs"], ["bad.pvs", "old.pvs"]] {
        let (code, _, stderr) = diff(d, &args);
        assert_eq!(code, Some(2));
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    }
}

#[test]
fn diff_of_two_bakes_of_an_edited_city_names_the_removed_building() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bin = env!("CARGO_BIN_EXE_citypvs");
    let ok = |args: &[&str]| {
        let o = Command::new(bin)
            .current_dir(d)
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    ok(&[
        "generate",
        "--buildings",
        "10",
        "--seed",
        "2",
        "-o",
        "a.geojson",
    ]);
    let mut city: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("a.geojson")).unwrap()).unwrap();
    let removed = city["features"].as_array_mut().unwrap().remove(3);
    std::fs::write(d.join("b.geojson"), city.to_string()).unwrap();
    ok(&["bake", "a.geojson", "-q"]);
    ok(&["bake", "b.geojson", "-q"]);
    let (code, stdout, stderr) = diff(d, &["a.pvs", "b.pvs", "--json"]);
    assert_eq!(code, Some(1), "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let id = citypvs::pvs::PvsReader::open(&d.join("a.pvs"))
        .unwrap()
        .object_ids()
        .to_vec();
    let gone: Vec<&String> = id
        .iter()
        .filter(|i| {
            !citypvs::pvs::PvsReader::open(&d.join("b.pvs"))
                .unwrap()
                .object_ids()
                .contains(i)
        })
        .collect();
    assert_eq!(gone.len(), 1, "{removed}");
    assert_eq!(v["objects_removed"], serde_json::json!([gone[0]]));
    assert!(
        v["header_changes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|h| h == "input (SHA-256)")
    );
    // Some cell lost the removed building.
    assert!(
        v["changed"].as_array().unwrap().iter().any(|c| c["lost"]
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l == gone[0]))
    );
}

/// Every setting the header records is compared, the near-field half-size
/// and the minimum gap as well as eps and the rest.
#[test]
fn diff_names_every_changed_setting() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let a = data(&["a"], &[0.0], vec![vec![0]]);
    let mut b = data(&["a"], &[0.0], vec![vec![0]]);
    b.info.numbers.near_field = 40.0;
    b.info.numbers.min_gap = 0.5;
    b.info.numbers.eps = 2.0;
    b.info.numbers.pixel = 2.8;
    write_pvs(&d.join("a.pvs"), &a).unwrap();
    write_pvs(&d.join("b.pvs"), &b).unwrap();
    let (code, stdout, stderr) = diff(d, &["a.pvs", "b.pvs", "--json"]);
    assert_eq!(code, Some(0), "same sets: {stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(
        v["header_changes"],
        serde_json::json!([
            "eps: 1 -> 2",
            "pixel: 1.4 -> 2.8",
            "near-field: 48 -> 40",
            "min-gap: 0 -> 0.5"
        ])
    );
}
