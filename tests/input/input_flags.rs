//! A flag that cannot apply to the input's format is refused, never
//! ignored: CityJSON is always in metres and takes its heights from its
//! geometry, OSM PBF is always lon/lat.

use std::path::Path;
use std::process::Command;

fn prepare(file: &str, extra: &[&str]) -> (i32, String) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/input")
        .join(file);
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .arg("prepare")
        .arg(&path)
        .args(extra)
        .output()
        .expect("run citypvs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cityjson_refuses_metric_and_default_height() {
    let (code, err) = prepare("small-2.0.city.json", &[]);
    assert_eq!(code, 0, "{err}");
    let (code, err) = prepare("small-2.0.city.json", &["--metric"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--metric does not apply to CityJSON"), "{err}");
    let (code, err) = prepare("small-2.0.city.json", &["--default-height", "12"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--default-height does not apply to CityJSON"),
        "{err}"
    );
}
