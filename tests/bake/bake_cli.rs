//! The `bake` command end to end: the embedded default city on a fresh
//! checkout, a CityJSON city, the same bytes for any thread count, and the
//! file read back by `inspect` and the library reader.

use std::path::Path;
use std::process::Command;

use citypvs::pvs::PvsReader;

fn citypvs(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run citypvs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

#[test]
fn bake_without_a_city_bakes_the_default_city_and_inspect_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, stdout, stderr) = citypvs(dir.path(), &["bake", "--json"]);
    assert!(ok, "{stderr}");
    let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(summary["buildings"], 400);
    let cells = summary["cells"].as_u64().unwrap();
    assert!(cells > 500, "{summary}");
    let culled = summary["culled_fraction"].as_f64().unwrap();
    assert!(culled > 0.3 && culled < 1.0, "{summary}");
    let file = dir.path().join("default-city.pvs");
    let reader = PvsReader::open(&file).unwrap();
    assert_eq!(reader.cell_count() as u64, cells);
    assert_eq!(reader.object_ids().len(), 400);
    // The reader finds every cell by its centroid and the cell's set is not empty
    // (a cell always sees the walls around it).
    for cell in (0..reader.cell_count()).step_by(97) {
        let t = reader.cell_triangle(cell);
        let c = (t[0] + t[1] + t[2]) / 3.0;
        assert_eq!(reader.cell_at(c), Some(cell));
        assert!(!reader.visible_ids(cell).unwrap().is_empty());
    }
    let (ok, stdout, stderr) = citypvs(dir.path(), &["inspect", "default-city.pvs"]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains(&format!("cells:        {cells}")),
        "{stdout}"
    );
}

#[test]
fn a_cityjson_city_bakes() {
    let dir = tempfile::tempdir().unwrap();
    let city = fixture("input/small-2.0.city.json");
    let (ok, _, stderr) = citypvs(dir.path(), &["bake", &city, "-o", "small.pvs", "-q"]);
    assert!(ok, "{stderr}");
    let reader = PvsReader::open(&dir.path().join("small.pvs")).unwrap();
    assert!(reader.cell_count() > 10);
    assert!(!reader.object_ids().is_empty());
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, _, stderr) = citypvs(
        dir.path(),
        &[
            "generate",
            "--buildings",
            "80",
            "--seed",
            "3",
            "-o",
            "city.geojson",
        ],
    );
    assert!(ok, "{stderr}");
    let mut files = Vec::new();
    for threads in ["1", "2", "3"] {
        let out = format!("city-{threads}.pvs");
        let (ok, _, stderr) = citypvs(
            dir.path(),
            &[
                "bake",
                "city.geojson",
                "-o",
                &out,
                "--threads",
                threads,
                "-q",
            ],
        );
        assert!(ok, "{stderr}");
        files.push(std::fs::read(dir.path().join(out)).unwrap());
    }
    assert!(files[0].len() > 1000);
    assert_eq!(files[0], files[1]);
    assert_eq!(files[0], files[2]);
}

#[test]
fn a_pixel_too_large_for_eps_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let city = fixture("input/small-2.0.city.json");
    let (ok, _, stderr) = citypvs(
        dir.path(),
        &["bake", &city, "-o", "out.pvs", "--pixel", "2", "-q"],
    );
    assert!(!ok);
    assert!(stderr.contains("pixel * sqrt(2) / 2 <= eps"), "{stderr}");
    assert!(!dir.path().join("out.pvs").exists());
}
