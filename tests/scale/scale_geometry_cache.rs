//! `--geometry-cache FILE` on the command line: a second preparation of
//! the same city takes every shape from the file; a file that is not a
//! usable cache is reported in one line naming it, the command still
//! succeeds with the same result, and the file is rewritten; a cache that
//! would overwrite the command's own input or output is refused.

use super::common::{citypvs, citypvs_json, stderr, tiny_city};
use super::scale_resume::generate;

#[test]
fn a_second_preparation_takes_every_shape_from_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "city.geojson", "60", "5");
    let cells = |name: &str| std::fs::read(d.join(name)).unwrap();
    let args = |out: &'static str| {
        [
            "prepare",
            "city.geojson",
            "--geometry-cache",
            "geo.cache",
            "--export-cells",
            out,
        ]
    };
    let first = citypvs_json(d, &args("first.geojson"));
    let cache = &first["geometry_cache"];
    assert_eq!(cache["taken"], 0, "{cache}");
    let made = cache["computed"].as_u64().unwrap();
    assert!(made > 0 && cache["written"] == made, "{cache}");
    let second = citypvs_json(d, &args("second.geojson"));
    let cache = &second["geometry_cache"];
    assert_eq!(cache["taken"], made, "{cache}");
    assert_eq!(cache["computed"], 0, "{cache}");
    citypvs_json(
        d,
        &["prepare", "city.geojson", "--export-cells", "plain.geojson"],
    );
    assert!(cells("second.geojson") == cells("plain.geojson"));
    assert!(cells("first.geojson") == cells("plain.geojson"));
}

#[test]
fn an_unusable_cache_is_reported_and_rewritten() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("city.geojson"), tiny_city(9)).unwrap();
    let good = citypvs_json(
        d,
        &[
            "prepare",
            "city.geojson",
            "--metric",
            "--geometry-cache",
            "geo.cache",
        ],
    );
    let mut bytes = std::fs::read(d.join("geo.cache")).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    for (name, damaged) in [
        ("flipped", bytes.clone()),
        ("cut", bytes[..40].to_vec()),
        ("other", b"not a cache at all".to_vec()),
    ] {
        std::fs::write(d.join("geo.cache"), &damaged).unwrap();
        let out = citypvs(
            d,
            &[
                "prepare",
                "city.geojson",
                "--metric",
                "--geometry-cache",
                "geo.cache",
                "--json",
            ],
        );
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(
            err.contains("ignoring geometry cache")
                && err.contains("geo.cache")
                && err.lines().count() == 1,
            "{name}: {err}"
        );
        let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert!(summary["geometry_cache"]["ignored"].is_string(), "{name}");
        assert_eq!(summary["cells"], good["cells"], "{name}");
        // Rewritten: the next run takes everything.
        let next = citypvs_json(
            d,
            &[
                "prepare",
                "city.geojson",
                "--metric",
                "--geometry-cache",
                "geo.cache",
            ],
        );
        assert_eq!(next["geometry_cache"]["computed"], 0, "{name}");
    }
}

#[test]
fn a_cache_that_is_an_input_or_the_output_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("city.geojson"), tiny_city(9)).unwrap();
    for args in [
        vec![
            "prepare",
            "city.geojson",
            "--metric",
            "--geometry-cache",
            "city.geojson",
        ],
        vec![
            "bake",
            "city.geojson",
            "--metric",
            "-o",
            "out.pvs",
            "--geometry-cache",
            "out.pvs",
        ],
        vec![
            "prepare",
            "city.geojson",
            "--metric",
            "--geometry-cache",
            "-",
        ],
        vec![
            "prepare",
            "city.geojson",
            "--metric",
            "--geometry-cache",
            ".",
        ],
    ] {
        let out = citypvs(d, &args);
        assert!(!out.status.success(), "{args:?}");
        let err = stderr(&out);
        assert!(err.lines().count() == 1, "{args:?}: {err}");
    }
    assert!(!d.join("out.pvs").exists());
    assert!(std::fs::read_to_string(d.join("city.geojson")).unwrap() == tiny_city(9));
}
