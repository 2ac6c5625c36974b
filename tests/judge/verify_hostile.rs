//! `verify` never passes a file it cannot really judge: a header no bake
//! writes (a NaN eye height, a zero eps), a file with no cells, cells that
//! are not the city's, and cells whose every viewpoint is inside a building
//! all exit 2; a genuine bake (also with a region) still passes.

use crate::common::citypvs;
use std::path::Path;
use std::process::Output;

use citypvs::pvs::{PvsData, PvsReader, write_pvs};
use glam::DVec2;

const CITY: &str = r#"{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"id":"a","height":10},"geometry":{"type":"Polygon","coordinates":[[[0,0],[20,0],[20,20],[0,20],[0,0]]]}},
{"type":"Feature","properties":{"id":"b","height":12},"geometry":{"type":"Polygon","coordinates":[[[40,0],[60,0],[60,20],[40,20],[40,0]]]}},
{"type":"Feature","properties":{"id":"c","height":30},"geometry":{"type":"Polygon","coordinates":[[[20,40],[40,40],[40,60],[20,60],[20,40]]]}}
]}"#;

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// A folder with the city and its genuine bake `good.pvs`.
fn baked() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("city.geojson"), CITY).unwrap();
    let out = citypvs(
        dir.path(),
        &["bake", "city.geojson", "--metric", "-q", "-o", "good.pvs"],
    );
    assert!(out.status.success(), "{}", text(&out));
    dir
}

fn verify(dir: &Path, pvs: &str, extra: &[&str]) -> Output {
    let mut args = vec!["verify", "city.geojson", pvs, "--metric", "--samples", "8"];
    args.extend_from_slice(extra);
    citypvs(dir, &args)
}

/// The genuine bake, changed by `edit`, written as `name`.
fn tampered(dir: &Path, name: &str, edit: impl FnOnce(&mut PvsData)) {
    let reader = PvsReader::open(&dir.join("good.pvs")).unwrap();
    let mut data = PvsData {
        object_prints: Vec::new(),
        info: reader.info().clone(),
        object_ids: reader.object_ids().to_vec(),
        cells: reader.cell_triangles().to_vec(),
        visible: (0..reader.cell_count())
            .map(|c| reader.visible(c).unwrap())
            .collect(),
    };
    edit(&mut data);
    write_pvs(&dir.join(name), &data).unwrap();
}

/// Copy `from` to `to` with one header number replaced (checksum fixed).
fn with_number(dir: &Path, from: &str, to: &str, offset: usize, value: f64) {
    let bytes = std::fs::read(dir.join(from)).unwrap();
    std::fs::write(
        dir.join(to),
        crate::common::with_header_number(bytes, offset, value),
    )
    .unwrap();
}

#[test]
fn a_genuine_bake_passes() {
    let dir = baked();
    let out = verify(dir.path(), "good.pvs", &["--all", "--json"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["passed"], true);
    assert_eq!(v["cells_match_city"], true);
}

#[test]
fn a_nan_eye_height_with_empty_sets_is_not_a_valid_bake() {
    let dir = baked();
    tampered(dir.path(), "empty-sets.pvs", |d| {
        d.visible.iter_mut().for_each(Vec::clear);
    });
    with_number(
        dir.path(),
        "empty-sets.pvs",
        "nan.pvs",
        crate::common::HEADER_EYE_HEIGHT,
        f64::NAN,
    );
    let out = verify(dir.path(), "nan.pvs", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    let t = text(&out);
    assert!(
        t.contains("nan.pvs: the file's header is not a valid bake")
            && t.contains("eye-height must be a positive number of metres, got NaN"),
        "{t}"
    );
    assert!(!t.contains("PASS"), "{t}");
}

#[test]
fn other_impossible_headers_are_refused() {
    let dir = baked();
    let edits = [
        ("eps", crate::common::HEADER_EPS, 0.0),
        ("pixel", crate::common::HEADER_PIXEL, 1e9),
        ("eye-height", crate::common::HEADER_EYE_HEIGHT, -1.7),
        (
            "max-cell-edge",
            crate::common::HEADER_MAX_CELL_EDGE,
            f64::INFINITY,
        ),
    ];
    for (what, offset, value) in edits {
        with_number(dir.path(), "good.pvs", "bad.pvs", offset, value);
        let out = verify(dir.path(), "bad.pvs", &[]);
        assert_eq!(out.status.code(), Some(2), "{what}: {}", text(&out));
        assert!(
            text(&out).contains(&format!("not a valid bake: {what} ")),
            "{}",
            text(&out)
        );
    }
}

#[test]
fn a_file_with_no_cells_is_never_a_pass() {
    let dir = baked();
    tampered(dir.path(), "empty.pvs", |d| {
        d.cells.clear();
        d.visible.clear();
    });
    for extra in [&[][..], &["--any-cells"][..]] {
        let out = verify(dir.path(), "empty.pvs", extra);
        assert_eq!(out.status.code(), Some(2), "{}", text(&out));
        assert!(text(&out).contains("no cells"), "{}", text(&out));
    }
}

#[test]
fn cells_that_are_not_the_citys_are_refused() {
    let dir = baked();
    // Fewer cells.
    tampered(dir.path(), "half.pvs", |d| {
        let n = d.cells.len() / 2;
        d.cells.truncate(n);
        d.visible.truncate(n);
    });
    let out = verify(dir.path(), "half.pvs", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("are not the"), "{}", text(&out));
    // As many cells, one moved.
    tampered(dir.path(), "moved.pvs", |d| {
        d.cells[3][0] += DVec2::new(0.5, 0.0)
    });
    let out = verify(dir.path(), "moved.pvs", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("cell 3 differs"), "{}", text(&out));
    // Baked with other scene settings than its header says.
    tampered(dir.path(), "edge.pvs", |d| {
        d.info.numbers.max_cell_edge *= 2.0
    });
    let out = verify(dir.path(), "edge.pvs", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
}

#[test]
fn a_region_bake_passes_with_its_region_and_is_refused_without() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("city.geojson"), CITY).unwrap();
    std::fs::write(
        dir.path().join("region.geojson"),
        r#"{"type":"Polygon","coordinates":[[[-10,-10],[70,-10],[70,70],[-10,70],[-10,-10]]]}"#,
    )
    .unwrap();
    let out = citypvs(
        dir.path(),
        &[
            "bake",
            "city.geojson",
            "--metric",
            "-q",
            "--region",
            "region.geojson",
            "-o",
            "r.pvs",
        ],
    );
    assert!(out.status.success(), "{}", text(&out));
    let out = verify(dir.path(), "r.pvs", &["--region", "region.geojson"]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let out = verify(dir.path(), "r.pvs", &[]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("--region"), "{}", text(&out));
}

#[test]
fn cells_whose_every_viewpoint_is_inside_a_building_are_not_a_pass() {
    let dir = baked();
    // One hand-made cell well inside building "c" (20..40 x 40..60 in the
    // file's metres); the frame's origin is the buildings' centre (30, 30).
    tampered(dir.path(), "inside.pvs", |d| {
        let q = |x: f64, y: f64| DVec2::new(x - 30.0, y - 30.0);
        d.cells = vec![[q(25.0, 45.0), q(35.0, 45.0), q(30.0, 55.0)]];
        d.visible = vec![vec![]];
    });
    let out = verify(dir.path(), "inside.pvs", &["--any-cells"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("nothing was judged"), "{}", text(&out));
}
