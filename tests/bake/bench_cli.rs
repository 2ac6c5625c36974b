//! `citypvs bench`: its figures are those of `citypvs bake` on the same
//! generated city, `--save` keeps them and `--baseline` sets a later run
//! beside them; a file that is not a saved run is refused; `--repeat`
//! reports the run of median time with the spread of all of them.

use crate::common::{citypvs, citypvs_json, stderr};

/// The JSON lines `citypvs ARGS` printed, after requiring success.
fn json_lines(dir: &std::path::Path, args: &[&str]) -> Vec<serde_json::Value> {
    let out = citypvs(dir, args);
    assert!(out.status.success(), "{}", stderr(&out));
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("one JSON object per line"))
        .collect()
}

/// `bench` of the generated cities of seed 3 and the given sizes, then
/// `extra`.
fn bench_of<'a>(buildings: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["bench", "--buildings", buildings, "--seed", "3"];
    args.extend_from_slice(extra);
    args
}

/// `bench` of the 60-building generated city of seed 3, then `extra`.
fn bench_small<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    bench_of("60", extra)
}

#[test]
fn bench_measures_the_bake_command_and_compares_with_a_saved_run() {
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("run.json");
    let saved_arg = saved.display().to_string();
    let rows = json_lines(
        dir.path(),
        &bench_small(&["--threads", "2", "--json", "--save", &saved_arg]),
    );
    assert_eq!(rows.len(), 1, "{rows:?}");
    let row = &rows[0];

    // The same city through `generate` and `bake`: the same cells, sets and
    // file size, so the bench times what the command does.
    let city = dir.path().join("c.geojson");
    let city_arg = city.display().to_string();
    let out = citypvs(
        dir.path(),
        &[
            "generate",
            "--buildings",
            "60",
            "--seed",
            "3",
            "-o",
            &city_arg,
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let bake = citypvs_json(dir.path(), &["bake", &city_arg, "-o", "c.pvs", "-q"]);
    for key in [
        "cells",
        "samples",
        "mean_visible",
        "max_visible",
        "file_bytes",
    ] {
        assert_eq!(
            row[key], bake[key],
            "{key}: bench {row} against bake {bake}"
        );
    }
    assert!(row["cells"].as_u64().unwrap() > 0, "{row}");
    assert!(row["cells_per_second"].as_f64().unwrap() > 0.0, "{row}");
    // No checkpoint or output is left behind in the working folder.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.contains("checkpoint") || n.starts_with("bench-"))
        .collect();
    assert!(left.is_empty(), "{left:?}");

    // The saved run holds the row; a second run set beside it.
    let text = std::fs::read_to_string(&saved).unwrap();
    let run: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(run["rows"][0]["cells"], row["cells"], "{run}");
    let lines = json_lines(
        dir.path(),
        &bench_small(&["--threads", "1", "--json", "--baseline", &saved_arg]),
    );
    assert_eq!(lines.len(), 2, "{lines:?}");
    let compared = &lines[1];
    assert_eq!(compared["buildings"], 60, "{compared}");
    let ratio = &compared["ratio_now_to_baseline"];
    // The sets do not depend on the thread count: the same cells and PVS.
    assert_eq!(ratio["cells"].as_f64(), Some(1.0), "{compared}");
    assert_eq!(ratio["mean_visible"].as_f64(), Some(1.0), "{compared}");
    assert!(ratio["bake_seconds"].as_f64().unwrap() > 0.0, "{compared}");

    // The table form names the figures and their ratio.
    let out = citypvs(dir.path(), &bench_small(&["--baseline", &saved_arg]));
    assert!(out.status.success(), "{}", stderr(&out));
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("60 buildings vs baseline"), "{table}");
    assert!(table.contains("cells_per_second"), "{table}");
    assert!(table.contains("now/base"), "{table}");
}

#[test]
fn bench_refuses_a_baseline_that_is_not_a_saved_run() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("notes.json"), "{\"rows\": 3}").unwrap();
    let out = citypvs(
        dir.path(),
        &["bench", "--buildings", "20", "--baseline", "notes.json"],
    );
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("notes.json") && e.contains("citypvs bench --save"),
        "{e}"
    );
    // Refused before any city is generated or baked.
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}

#[test]
fn bench_sets_each_larger_city_beside_the_smallest() {
    let dir = tempfile::tempdir().unwrap();
    let lines = json_lines(
        dir.path(),
        &bench_of("60,30", &["--threads", "1", "--json"]),
    );
    assert_eq!(lines.len(), 3, "{lines:?}");
    let (big, small, scaling) = (&lines[0], &lines[1], &lines[2]);
    for row in [big, small] {
        let pairs = row["mean_visible"].as_f64().unwrap() * row["cells"].as_f64().unwrap()
            / row["bake_seconds"].as_f64().unwrap();
        let got = row["visible_pairs_per_second"].as_f64().unwrap();
        assert!((got - pairs).abs() <= 1e-9 * pairs, "{row}");
    }
    assert_eq!(scaling["buildings"], 60, "{scaling}");
    assert_eq!(scaling["against_buildings"], 30, "{scaling}");
    let ratio = |key: &str| big[key].as_f64().unwrap() / small[key].as_f64().unwrap();
    for (key, of) in [
        ("cells_per_second_ratio", "cells_per_second"),
        ("visible_pairs_per_second_ratio", "visible_pairs_per_second"),
    ] {
        let got = scaling[key].as_f64().unwrap();
        assert!(
            (got - ratio(of)).abs() <= 1e-9 * got.abs(),
            "{key}: {scaling}"
        );
    }
    // Cells per CPU second: the smaller city's CPU time per cell over the
    // larger one's.
    if cfg!(target_os = "linux") {
        let want = small["cpu_micros_per_cell"].as_f64().unwrap()
            / big["cpu_micros_per_cell"].as_f64().unwrap();
        let got = scaling["cells_per_cpu_second_ratio"].as_f64().unwrap();
        assert!((got - want).abs() <= 1e-9 * want, "{scaling}");
    }
}

#[test]
fn bench_repeats_a_bake_and_reports_the_median_run_with_its_spread() {
    let dir = tempfile::tempdir().unwrap();
    let lines = json_lines(
        dir.path(),
        &bench_small(&["--threads", "1", "--json", "--repeat", "3"]),
    );
    assert_eq!(lines.len(), 1, "{lines:?}");
    let row = &lines[0];
    assert_eq!(row["runs"], 3, "{row}");
    let figure = |key: &str| row[key].as_f64().unwrap();
    let (lo, median, hi) = (
        figure("bake_seconds_min"),
        figure("bake_seconds"),
        figure("bake_seconds_max"),
    );
    assert!(0.0 < lo && lo <= median && median <= hi, "{row}");
    // The median run's figures are consistent with its time.
    let cells = figure("cells");
    assert!(
        (figure("cells_per_second") - cells / median).abs() <= 1e-9 * cells / median,
        "{row}"
    );
    // The bake's CPU time is counted (Linux tells it), per cell as well.
    if cfg!(target_os = "linux") {
        let cpu = figure("cpu_seconds");
        assert!(cpu > 0.0, "{row}");
        assert!(
            (figure("cpu_micros_per_cell") - 1e6 * cpu / cells).abs() <= 1e-6 * cpu,
            "{row}"
        );
    }

    // Zero repeats is refused before anything is baked.
    let out = citypvs(dir.path(), &bench_small(&["--repeat", "0"]));
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--repeat"), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
}

#[test]
fn bench_repeats_in_rounds_of_every_city() {
    let dir = tempfile::tempdir().unwrap();
    let out = citypvs(
        dir.path(),
        &bench_of("30,60", &["--threads", "1", "--json", "--repeat", "2"]),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    // Each city once a round, in the order given.
    let runs: Vec<String> = stderr(&out)
        .lines()
        .filter_map(|l| l.strip_prefix("bench: "))
        .map(|l| l.split(':').next().unwrap().to_string())
        .collect();
    assert_eq!(
        runs,
        [
            "30 buildings, run 1 of 2",
            "60 buildings, run 1 of 2",
            "30 buildings, run 2 of 2",
            "60 buildings, run 2 of 2",
        ],
        "{}",
        stderr(&out)
    );
    let rows: Vec<serde_json::Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(rows.len(), 3, "{rows:?}");
    assert_eq!(
        (rows[0]["buildings"].clone(), rows[1]["buildings"].clone()),
        (30.into(), 60.into())
    );
    assert!(rows[..2].iter().all(|r| r["runs"] == 2), "{rows:?}");
}
