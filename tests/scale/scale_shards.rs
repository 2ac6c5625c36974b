//! Sharded bakes end to end: four `citypvs bake --shard K/4` processes at
//! once, merged, give the bytes of one bake; `--shard auto/N` reads its K
//! from the batch systems' variables; `merge` refuses shards that do not
//! belong together, with one line naming the file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_citypvs"))
}

fn run(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = bin();
    cmd.current_dir(dir).args(args);
    for var in [
        "JOB_COMPLETION_INDEX",
        "SLURM_ARRAY_TASK_ID",
        "CITYPVS_SHARD",
    ] {
        cmd.env_remove(var);
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run citypvs")
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let out = run(dir, args, &[]);
    assert!(
        out.status.success(),
        "citypvs {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The one error line of a failed run (exit status 2).
fn fails(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> String {
    let out = run(dir, args, env);
    assert_eq!(out.status.code(), Some(2), "citypvs {args:?} should fail");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    stderr
}

fn city(dir: &Path, name: &str, buildings: usize, seed: u64) -> PathBuf {
    let (b, s) = (buildings.to_string(), seed.to_string());
    ok(
        dir,
        &["generate", "--buildings", &b, "--seed", &s, "-o", name],
    );
    dir.join(name)
}

#[test]
fn four_shard_processes_at_once_merge_into_the_bytes_of_one_bake() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    city(d, "city.geojson", 20, 11);
    ok(d, &["bake", "city.geojson", "-o", "full.pvs", "-q"]);
    let procs: Vec<_> = (0..4)
        .map(|k| {
            bin()
                .current_dir(d)
                .args(["bake", "city.geojson", "-q", "--json", "--threads", "1"])
                .args(["--shard", &format!("{k}/4")])
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let mut ranges = Vec::new();
    let mut samples = Vec::new();
    for (k, p) in procs.into_iter().enumerate() {
        let out = p.wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let s: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(s["shard"], format!("{k}/4"));
        assert_eq!(s["output"], format!("city.shard-{k}-of-4"));
        // The probes of the split are timed as a stage of their own.
        let stages: Vec<&str> = s["timings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["stage"].as_str().unwrap())
            .collect();
        assert!(stages.contains(&"split"), "{stages:?}");
        ranges.push((
            s["cell_range"][0].as_u64().unwrap(),
            s["cell_range"][1].as_u64().unwrap(),
        ));
        samples.push(s["samples"].as_u64().unwrap());
    }
    // Contiguous ranges covering the cells, none without samples (the
    // balance of the work is tested in `scale_balance`).
    assert_eq!(ranges[0].0, 0);
    for w in ranges.windows(2) {
        assert_eq!(w[0].1, w[1].0);
    }
    assert!(samples.iter().all(|&s| s > 0), "{samples:?}");
    let merged = ok(
        d,
        &[
            "merge",
            "city.shard-2-of-4",
            "city.shard-0-of-4",
            "city.shard-3-of-4",
            "city.shard-1-of-4",
            "-o",
            "merged.pvs",
        ],
    );
    assert!(merged.contains("merged 4 shards"), "{merged}");
    let full = std::fs::read(d.join("full.pvs")).unwrap();
    assert_eq!(ranges[3].1 as usize, {
        let r = citypvs::pvs::PvsReader::open(&d.join("full.pvs")).unwrap();
        r.cell_count()
    });
    assert!(
        std::fs::read(d.join("merged.pvs")).unwrap() == full,
        "merged bytes differ from one bake"
    );
    // No checkpoints are left behind.
    let left: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".citypvs-checkpoint"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn merge_refuses_shards_that_do_not_belong_together() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    city(d, "city.geojson", 8, 5);
    city(d, "other.geojson", 8, 6);
    for k in 0..3 {
        ok(
            d,
            &["bake", "city.geojson", "-q", "--shard", &format!("{k}/3")],
        );
    }
    let s = |k: usize| format!("city.shard-{k}-of-3");
    ok(d, &["merge", &s(0), &s(1), &s(2), "-o", "ok.pvs"]);
    // Another input, other settings, another N.
    ok(
        d,
        &[
            "bake",
            "other.geojson",
            "-q",
            "--shard",
            "1/3",
            "-o",
            "other-1",
        ],
    );
    ok(
        d,
        &[
            "bake",
            "city.geojson",
            "-q",
            "--shard",
            "1/3",
            "--eps",
            "1.2",
            "-o",
            "eps-1",
        ],
    );
    ok(
        d,
        &[
            "bake",
            "city.geojson",
            "-q",
            "--shard",
            "1/2",
            "-o",
            "half-1",
        ],
    );
    for (file, needle) in [
        ("other-1", "input"),
        ("eps-1", "eps"),
        ("half-1", "number of shards"),
    ] {
        let err = fails(d, &["merge", &s(0), file, &s(2), "-o", "bad.pvs"], &[]);
        assert!(
            err.contains(file) && err.contains("different bakes") && err.contains(needle),
            "{err}"
        );
    }
    let err = fails(d, &["merge", &s(0), &s(2), "-o", "bad.pvs"], &[]);
    assert!(err.contains("missing shard 1 of 3"), "{err}");
    let err = fails(
        d,
        &["merge", &s(0), &s(1), &s(1), &s(2), "-o", "bad.pvs"],
        &[],
    );
    assert!(err.contains("given twice") && err.contains(&s(1)), "{err}");
    // A truncated and a corrupted copy of shard 1.
    let bytes = std::fs::read(d.join(s(1))).unwrap();
    std::fs::write(d.join("cut-1"), &bytes[..bytes.len() - 10]).unwrap();
    let mut flipped = bytes.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x40;
    std::fs::write(d.join("flip-1"), &flipped).unwrap();
    std::fs::write(d.join("junk-1"), b"not a shard at all").unwrap();
    for (file, needle) in [
        ("cut-1", "truncated"),
        ("flip-1", "corrupted"),
        ("junk-1", "not a citypvs shard"),
    ] {
        let err = fails(d, &["merge", &s(0), file, &s(2), "-o", "bad.pvs"], &[]);
        assert!(err.contains(file) && err.contains(needle), "{err}");
    }
    // An unfinished shard's checkpoint is not a shard.
    let mut cp = citypvs::scale::part::Part::read(&d.join(s(1))).unwrap();
    cp.kind = citypvs::scale::part::PartKind::Checkpoint;
    let kept = cp.done() - 1;
    cp.truncate_sets(kept).unwrap();
    cp.write(&d.join("cp-1")).unwrap();
    let err = fails(d, &["merge", &s(0), "cp-1", &s(2), "-o", "bad.pvs"], &[]);
    assert!(err.contains("cp-1") && err.contains("checkpoint"), "{err}");
    let err = fails(
        d,
        &["merge", &s(0), "nowhere-1", &s(2), "-o", "bad.pvs"],
        &[],
    );
    assert!(err.contains("nowhere-1"), "{err}");
    assert!(
        !d.join("bad.pvs").exists(),
        "a refused merge wrote its output"
    );
}

#[test]
fn shard_auto_reads_k_from_the_first_variable_set_and_refuses_bad_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    city(d, "city.geojson", 8, 5);
    ok(
        d,
        &[
            "bake",
            "city.geojson",
            "-q",
            "--shard",
            "1/3",
            "-o",
            "fixed",
        ],
    );
    let auto = |out: &str, env: &[(&str, &str)]| {
        let o = run(
            d,
            &[
                "bake",
                "city.geojson",
                "-q",
                "--json",
                "--shard",
                "auto/3",
                "-o",
                out,
            ],
            env,
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        s["shard_from"].as_str().unwrap().to_string()
    };
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    assert_eq!(auto("a", &[("CITYPVS_SHARD", "1")]), "CITYPVS_SHARD");
    assert_eq!(
        auto("b", &[("SLURM_ARRAY_TASK_ID", "1"), ("CITYPVS_SHARD", "2")]),
        "SLURM_ARRAY_TASK_ID"
    );
    assert_eq!(
        auto(
            "c",
            &[("JOB_COMPLETION_INDEX", "1"), ("SLURM_ARRAY_TASK_ID", "0")]
        ),
        "JOB_COMPLETION_INDEX"
    );
    for f in ["a", "b", "c"] {
        assert!(read(f) == read("fixed"), "{f} differs from --shard 1/3");
    }
    let err = fails(
        d,
        &["bake", "city.geojson", "-q", "--shard", "auto/3"],
        &[("CITYPVS_SHARD", "3")],
    );
    assert!(err.contains("no shard 3 of 3"), "{err}");
    let err = fails(
        d,
        &["bake", "city.geojson", "-q", "--shard", "auto/3"],
        &[("JOB_COMPLETION_INDEX", "x")],
    );
    assert!(
        err.contains("JOB_COMPLETION_INDEX") && err.contains("not a shard number"),
        "{err}"
    );
    let err = fails(d, &["bake", "city.geojson", "-q", "--shard", "auto/3"], &[]);
    assert!(err.contains("CITYPVS_SHARD"), "{err}");
    for bad in ["3/3", "one/3", "1/0", "7"] {
        let err = fails(d, &["bake", "city.geojson", "-q", "--shard", bad], &[]);
        assert!(err.contains("shard"), "{err}");
    }
    let help = ok(d, &["bake", "--help"]);
    for var in [
        "JOB_COMPLETION_INDEX",
        "SLURM_ARRAY_TASK_ID",
        "CITYPVS_SHARD",
    ] {
        assert!(help.contains(var), "--help does not name {var}");
    }
}
