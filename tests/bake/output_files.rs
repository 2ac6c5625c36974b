//! How citypvs writes its output files: regular files atomically, devices,
//! FIFOs and standard output written through and never replaced, symbolic
//! links followed, an input never overwritten, errors naming the user's
//! path, and temporary files that say what they are and do not pile up.

use crate::common::{citypvs, stderr};
use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;

/// A small metric city that bakes in well under a second.
const SMALL_CITY: &str = r#"{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"id":"a","height":10},"geometry":{"type":"Polygon","coordinates":[[[0,0],[20,0],[20,20],[0,20],[0,0]]]}},
{"type":"Feature","properties":{"id":"b","height":12},"geometry":{"type":"Polygon","coordinates":[[[40,0],[60,0],[60,20],[40,20],[40,0]]]}}
]}"#;

fn small_city(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("city.geojson");
    fs::write(&path, SMALL_CITY).unwrap();
    path
}

fn is_char_device(path: &str) -> bool {
    fs::symlink_metadata(path)
        .map(|m| m.file_type().is_char_device())
        .unwrap_or(false)
}

/// Files in `dir` whose name holds the temporary-file marker.
fn temporaries(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("citypvs-tmp") || n.starts_with(".tmp"))
        .collect()
}

#[test]
fn bake_generate_and_render_to_dev_null_succeed_and_leave_the_device_alone() {
    let dir = tempfile::tempdir().unwrap();
    small_city(dir.path());
    let runs: [&[&str]; 3] = [
        &["bake", "city.geojson", "--metric", "-q", "-o", "/dev/null"],
        &["generate", "--buildings", "3", "-o", "/dev/null"],
        &["render", "city.geojson", "--metric", "-o", "/dev/null"],
    ];
    for args in runs {
        let out = citypvs(dir.path(), args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        assert!(is_char_device("/dev/null"), "{args:?} replaced /dev/null");
    }
}

#[test]
fn writing_to_dev_full_fails_with_exit_2_and_leaves_the_device_alone() {
    let dir = tempfile::tempdir().unwrap();
    small_city(dir.path());
    let runs: [&[&str]; 3] = [
        &["bake", "city.geojson", "--metric", "-q", "-o", "/dev/full"],
        &["generate", "--buildings", "3", "-o", "/dev/full"],
        &["render", "city.geojson", "--metric", "-o", "/dev/full"],
    ];
    for args in runs {
        let out = citypvs(dir.path(), args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        let e = stderr(&out);
        assert!(e.contains("/dev/full") && e.contains("cannot write"), "{e}");
        assert!(is_char_device("/dev/full"), "{args:?} replaced /dev/full");
    }
}

#[test]
fn a_fifo_is_written_through_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || fs::read(&fifo).unwrap())
    };
    let out = citypvs(
        dir.path(),
        &["generate", "--buildings", "3", "-o", fifo.to_str().unwrap()],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let bytes = reader.join().unwrap();
    let json: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(json["features"].as_array().unwrap().len(), 3);
    let kind = fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo(), "the FIFO was replaced by {kind:?}");
}

#[test]
fn dash_writes_the_file_to_standard_output_and_the_summary_to_standard_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = citypvs(dir.path(), &["generate", "--buildings", "3", "-o", "-"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["features"].as_array().unwrap().len(), 3);
    assert!(
        stderr(&out).contains("wrote 3 buildings"),
        "{}",
        stderr(&out)
    );
    assert!(!dir.path().join("-").exists());
}

#[test]
fn a_symlink_output_replaces_its_target_and_the_link_stays() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.geojson");
    fs::write(&target, "old").unwrap();
    let link = dir.path().join("link.geojson");
    std::os::unix::fs::symlink("real.geojson", &link).unwrap();
    let out = citypvs(
        dir.path(),
        &["generate", "--buildings", "3", "-o", "link.geojson"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(fs::read_link(&link).unwrap(), Path::new("real.geojson"));
    let text = fs::read_to_string(&target).unwrap();
    assert!(text.contains("FeatureCollection"), "{text}");
    assert!(temporaries(dir.path()).is_empty());
}

#[test]
fn bake_refuses_to_overwrite_its_input_by_name_symlink_or_hard_link() {
    let dir = tempfile::tempdir().unwrap();
    small_city(dir.path());
    std::os::unix::fs::symlink("city.geojson", dir.path().join("alias.pvs")).unwrap();
    fs::hard_link(dir.path().join("city.geojson"), dir.path().join("hard.pvs")).unwrap();
    for output in ["city.geojson", "./city.geojson", "alias.pvs", "hard.pvs"] {
        let out = citypvs(
            dir.path(),
            &["bake", "city.geojson", "--metric", "-q", "-o", output],
        );
        assert_eq!(out.status.code(), Some(2), "-o {output}: {}", stderr(&out));
        let e = stderr(&out);
        assert!(e.contains("is the input"), "{e}");
        assert_eq!(
            fs::read_to_string(dir.path().join("city.geojson")).unwrap(),
            SMALL_CITY
        );
    }
}

#[test]
fn render_refuses_to_overwrite_its_pvs_input() {
    let dir = tempfile::tempdir().unwrap();
    small_city(dir.path());
    let out = citypvs(
        dir.path(),
        &["bake", "city.geojson", "--metric", "-q", "-o", "city.pvs"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let before = fs::read(dir.path().join("city.pvs")).unwrap();
    let out = citypvs(
        dir.path(),
        &[
            "render",
            "city.geojson",
            "--metric",
            "--pvs",
            "city.pvs",
            "-o",
            "city.pvs",
        ],
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("is the input"), "{}", stderr(&out));
    assert_eq!(fs::read(dir.path().join("city.pvs")).unwrap(), before);
}

#[test]
fn a_write_error_names_the_users_path_not_a_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    // /proc accepts no new files, even from root.
    let out = citypvs(
        dir.path(),
        &[
            "generate",
            "--buildings",
            "3",
            "-o",
            "/proc/citypvs.geojson",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(e.contains("/proc/citypvs.geojson: cannot write"), "{e}");
    assert!(!e.contains(".tmp") && !e.contains("citypvs-tmp"), "{e}");
}

#[test]
fn stale_temporary_files_of_the_same_output_are_removed_and_others_kept() {
    let dir = tempfile::tempdir().unwrap();
    // Process 4294967 cannot exist (above Linux's largest pid).
    let stale = dir.path().join(".out.geojson.citypvs-tmp-4294967-deadbeef");
    let other = dir
        .path()
        .join(".other.geojson.citypvs-tmp-4294967-deadbeef");
    fs::write(&stale, "half").unwrap();
    fs::write(&other, "half").unwrap();
    let out = citypvs(
        dir.path(),
        &["generate", "--buildings", "3", "-o", "out.geojson"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stale.exists(), "the stale temporary file is still there");
    assert!(
        other.exists(),
        "another output's temporary file was removed"
    );
    assert_eq!(
        temporaries(dir.path()),
        vec![".other.geojson.citypvs-tmp-4294967-deadbeef".to_string()]
    );
}

#[test]
fn an_output_in_a_missing_folder_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    small_city(dir.path());
    let out = citypvs(
        dir.path(),
        &[
            "bake",
            "city.geojson",
            "--metric",
            "-q",
            "-o",
            "nowhere/city.pvs",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("nowhere/city.pvs") && e.contains("does not exist"),
        "{e}"
    );
}
