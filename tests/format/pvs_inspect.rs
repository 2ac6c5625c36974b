//! `citypvs inspect` on a file written with `write_pvs`: text summary, full
//! JSON dump, a single cell, and errors for bad files and cell numbers.

use std::path::Path;
use std::process::Command;

use citypvs::input::Frame;
use citypvs::pvs::{BakeInfo, PvsData, write_pvs};
use glam::DVec2;

fn data() -> PvsData {
    let cells = vec![
        [
            DVec2::new(0.0, 0.0),
            DVec2::new(100.0, 0.0),
            DVec2::new(0.0, 100.0),
        ],
        [
            DVec2::new(100.0, 0.0),
            DVec2::new(100.0, 100.0),
            DVec2::new(0.0, 100.0),
        ],
        [
            DVec2::new(-50.0, -50.0),
            DVec2::new(0.0, -50.0),
            DVec2::new(0.0, 0.0),
        ],
    ];
    PvsData {
        object_prints: Vec::new(),
        info: BakeInfo {
            numbers: citypvs::BakeNumbers {
                eps: 0.5,
                eye_height: 1.6,
                pixel: 0.25,
                max_cell_edge: 120.0,
                margin: 10.0,
                near_field: 48.0,
                min_gap: 0.0,
            },
            frame: Frame::LonLat {
                lon0: 26.94,
                lat0: 60.47,
            },
            source_hash: [0xab; 32],
            region_hash: [0; 32],
            tool_version: "citypvs 9.9.9".into(),
        },
        object_ids: vec!["way/11".into(), "way/22".into(), "relation/33".into()],
        cells,
        visible: vec![vec![0, 2], vec![], vec![0, 1, 2]],
    }
}

fn inspect(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .arg("inspect")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

fn written(dir: &Path) -> String {
    let path = dir.join("city.pvs");
    write_pvs(&path, &data()).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn json_dump_holds_every_cell_with_ids_and_both_frames() {
    let dir = tempfile::tempdir().unwrap();
    let file = written(dir.path());
    let (ok, stdout, stderr) = inspect(&[&file, "--json"]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["header"]["tool_version"], "citypvs 9.9.9");
    assert_eq!(v["header"]["source_sha256"], "ab".repeat(32));
    assert_eq!(v["header"]["frame"]["kind"], "lon_lat");
    assert_eq!(v["header"]["frame"]["lat0"], 60.47);
    assert_eq!(v["stats"]["cells"], 3);
    assert_eq!(v["stats"]["objects"], 3);
    assert_eq!(v["stats"]["max_visible"], 3);
    assert_eq!(v["stats"]["mean_visible"], 5.0 / 3.0);
    let bytes = std::fs::metadata(&file).unwrap().len();
    assert_eq!(v["stats"]["file_bytes"], bytes);
    let cells = v["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 3);
    assert_eq!(cells[0]["index"], 0);
    assert_eq!(
        cells[0]["visible"],
        serde_json::json!(["way/11", "relation/33"])
    );
    assert_eq!(cells[1]["visible"], serde_json::json!([]));
    assert_eq!(
        cells[2]["visible"],
        serde_json::json!(["way/11", "way/22", "relation/33"])
    );
    assert_eq!(
        cells[1]["triangle_local"][1],
        serde_json::json!([100.0, 100.0])
    );
    // The local origin maps to the frame's centre (the inverse is good to 1e-8 degrees); 100 m north is about 0.0009 degrees.
    let p0 = &cells[0]["triangle_input"][0];
    assert!((p0[0].as_f64().unwrap() - 26.94).abs() < 1e-7);
    assert!((p0[1].as_f64().unwrap() - 60.47).abs() < 1e-7);
    let p2 = &cells[0]["triangle_input"][2];
    let dlat = p2[1].as_f64().unwrap() - 60.47;
    assert!((dlat - 100.0 / 111_400.0).abs() < 2e-6, "{dlat}");
}

#[test]
fn one_cell_only_with_cell_flag() {
    let dir = tempfile::tempdir().unwrap();
    let file = written(dir.path());
    let (ok, stdout, stderr) = inspect(&[&file, "--json", "--cell", "2"]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let cells = v["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 1);
    assert_eq!(cells[0]["index"], 2);
    assert_eq!(
        cells[0]["triangle_local"][0],
        serde_json::json!([-50.0, -50.0])
    );

    let (ok, stdout, _) = inspect(&[&file, "--cell", "0"]);
    assert!(ok);
    assert!(stdout.contains("cell 0:"), "{stdout}");
    assert!(
        stdout.contains("visible (2): way/11 relation/33"),
        "{stdout}"
    );
}

#[test]
fn text_summary_names_the_statistics() {
    let dir = tempfile::tempdir().unwrap();
    let file = written(dir.path());
    let (ok, stdout, stderr) = inspect(&[&file]);
    assert!(ok, "{stderr}");
    for needle in [
        "citypvs 9.9.9",
        "cells:        3",
        "objects:      3",
        "mean 1.7, max 3 per cell",
        "transverse Mercator",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in\n{stdout}");
    }
    assert!(!stdout.contains("cell 0:"));
}

#[test]
fn bad_cell_and_bad_file_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let file = written(dir.path());
    let (ok, _, stderr) = inspect(&[&file, "--cell", "3"]);
    assert!(!ok);
    assert!(stderr.contains("--cell 3 does not exist"), "{stderr}");

    let bytes = std::fs::read(&file).unwrap();
    let cut = dir.path().join("cut.pvs");
    std::fs::write(&cut, &bytes[..bytes.len() - 5]).unwrap();
    let (ok, _, stderr) = inspect(&[cut.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        stderr.contains("cut.pvs") && stderr.contains("truncated"),
        "{stderr}"
    );
}
