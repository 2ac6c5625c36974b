//! Every bake setting is checked once, before any work: absurd or broken
//! numbers are refused with exit status 2, a message naming the flag the
//! user gave (never another one), and no output file.

use std::process::Command;

fn bake(dir: &std::path::Path, extra: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .args(["bake", "-q", "-o", "out.pvs"])
        .args(extra)
        .output()
        .expect("run citypvs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn broken_and_absurd_numbers_are_refused_naming_their_own_flag() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str, &str); 8] = [
        (
            &["--eps", "0"],
            "--eps must be a positive number",
            "--pixel",
        ),
        (&["--eps", "1e9"], "--eps 1.000e9 m is absurd", "--pixel"),
        (
            &["--eps", "1e-6"],
            "--eps must be more than 0.0110 m",
            "--pixel",
        ),
        (&["--pixel", "1e-6"], "near-field cull map", "--eye-height"),
        (
            &["--eye-height", "1e300"],
            "--eye-height 1.000e300 m is absurd",
            "--eps",
        ),
        (
            &["--eye-height", "NaN"],
            "--eye-height must be a positive number",
            "--eps",
        ),
        (
            &["--max-cell-edge=-3"],
            "--max-cell-edge must be a positive",
            "--eps",
        ),
        (
            &["--margin", "inf"],
            "--margin must be zero or a positive",
            "--eps",
        ),
    ];
    for (args, expected, not_named) in cases {
        let (code, err) = bake(dir.path(), args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(
            !err.contains(not_named),
            "{args:?} names {not_named}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{args:?}: one line: {err}");
        assert!(
            !dir.path().join("out.pvs").exists(),
            "{args:?} wrote a file"
        );
    }
}

#[test]
fn a_pixel_too_large_for_eps_names_both_and_the_largest_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let (code, err) = bake(dir.path(), &["--eps", "0.5", "--pixel", "1"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--pixel 1 is too large for eps 0.5"), "{err}");
    assert!(err.contains("0.699294"), "{err}");
}

#[test]
fn settings_errors_have_a_kind_naming_the_setting() {
    use citypvs::{ErrorKind, RawSettings, Settings};
    let err = Settings::new(RawSettings {
        eps: Some(1e-6),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(err.kind(), &ErrorKind::Setting("eps"));
    let err = Settings::new(RawSettings {
        eps: Some(0.015),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(err.kind(), &ErrorKind::Limit("pixel"));
    let err = Settings::new(RawSettings {
        near_field: Some(-1.0),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(err.kind(), &ErrorKind::Setting("near-field"));
}
