//! Resume: a bake killed with SIGKILL after it saved a checkpoint, run
//! again, reads the checkpoint, solves only the rest and writes the bytes
//! of an uninterrupted bake; shards resume the same way; a checkpoint of
//! another bake, or a damaged one, is never used.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_citypvs"));
    for var in [
        "JOB_COMPLETION_INDEX",
        "SLURM_ARRAY_TASK_ID",
        "CITYPVS_SHARD",
    ] {
        c.env_remove(var);
    }
    c
}

fn run(dir: &Path, args: &[&str]) -> Output {
    let out = bin().current_dir(dir).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "citypvs {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn json(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Start `citypvs ARGS`, SIGKILL it as soon as `checkpoint` exists, and
/// return whether it was killed before it finished.
fn kill_after_checkpoint(dir: &Path, args: &[&str], checkpoint: &Path) -> bool {
    let mut child = bin()
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if checkpoint.exists() {
            child.kill().unwrap(); // SIGKILL on Unix
            child.wait().unwrap();
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no checkpoint appeared"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// `citypvs generate --buildings BUILDINGS --seed SEED -o NAME` in `dir`.
pub(super) fn generate(dir: &Path, name: &str, buildings: &str, seed: &str) {
    run(
        dir,
        &[
            "generate",
            "--buildings",
            buildings,
            "--seed",
            seed,
            "-o",
            name,
        ],
    );
}

#[test]
fn a_killed_bake_resumes_from_its_checkpoint_and_writes_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "city.geojson", "20", "11");
    let full = json(&run(
        d,
        &["bake", "city.geojson", "-o", "full.pvs", "-q", "--json"],
    ));
    let cells = full["cells"].as_u64().unwrap();
    assert_eq!(full["cells_from_checkpoint"], 0);
    assert!(
        full["checkpoints_written"].as_u64().unwrap() >= 10,
        "{full}"
    );
    assert!(!d.join("full.pvs.citypvs-checkpoint").exists());

    let cp = d.join("again.pvs.citypvs-checkpoint");
    let args = [
        "bake",
        "city.geojson",
        "-o",
        "again.pvs",
        "-q",
        "--json",
        "--threads",
        "1",
    ];
    assert!(
        kill_after_checkpoint(d, &args, &cp),
        "the bake finished before it was killed"
    );
    assert!(!d.join("again.pvs").exists());
    let saved = citypvs::scale::part::Part::read(&cp).unwrap();
    assert!(saved.done() > 0 && (saved.done() as u64) < cells);

    let out = run(d, &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let resumed = json(&out);
    let from = resumed["cells_from_checkpoint"].as_u64().unwrap();
    assert!(from >= saved.done() as u64 && from < cells, "{resumed}");
    assert!(
        stderr.contains(&format!(
            "resumed from checkpoint: {from} of {cells} cells done"
        )),
        "{stderr}"
    );
    // The statistics are those of the whole bake.
    for field in ["cells", "samples", "mean_visible", "max_visible"] {
        assert_eq!(resumed[field], full[field], "{field}");
    }
    assert!(
        std::fs::read(d.join("again.pvs")).unwrap() == std::fs::read(d.join("full.pvs")).unwrap()
    );
    assert!(!cp.exists(), "the checkpoint outlived a finished bake");
}

#[test]
fn a_killed_shard_resumes_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "city.geojson", "20", "11");
    run(
        d,
        &[
            "bake",
            "city.geojson",
            "-q",
            "--shard",
            "1/2",
            "-o",
            "whole-1",
        ],
    );
    let cp = d.join("city.shard-1-of-2.citypvs-checkpoint");
    let args = [
        "bake",
        "city.geojson",
        "-q",
        "--json",
        "--threads",
        "1",
        "--shard",
        "1/2",
    ];
    assert!(kill_after_checkpoint(d, &args, &cp));
    let resumed = json(&run(d, &args));
    assert!(
        resumed["cells_from_checkpoint"].as_u64().unwrap() > 0,
        "{resumed}"
    );
    assert!(
        std::fs::read(d.join("city.shard-1-of-2")).unwrap()
            == std::fs::read(d.join("whole-1")).unwrap()
    );
    assert!(!cp.exists());
}

#[test]
fn a_checkpoint_of_another_bake_or_a_damaged_one_is_not_used() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "city.geojson", "10", "4");
    generate(d, "other.geojson", "10", "5");
    run(d, &["bake", "city.geojson", "-o", "full.pvs", "-q"]);
    // A checkpoint of other settings, of another input, and a damaged one.
    let settings_cp = d.join("eps.pvs.citypvs-checkpoint");
    let eps_args = [
        "bake",
        "city.geojson",
        "-o",
        "eps.pvs",
        "-q",
        "--threads",
        "1",
        "--eps",
        "1.2",
    ];
    assert!(kill_after_checkpoint(d, &eps_args, &settings_cp));
    let input_cp = d.join("other.pvs.citypvs-checkpoint");
    let other_args = [
        "bake",
        "other.geojson",
        "-o",
        "other.pvs",
        "-q",
        "--threads",
        "1",
    ];
    assert!(kill_after_checkpoint(d, &other_args, &input_cp));
    let mut damaged = std::fs::read(&input_cp).unwrap();
    let n = damaged.len();
    damaged.truncate(n - 3);
    for (name, bytes, needle) in [
        ("a.pvs", std::fs::read(&settings_cp).unwrap(), "eps"),
        ("b.pvs", std::fs::read(&input_cp).unwrap(), "input"),
        ("c.pvs", damaged, "truncated"),
    ] {
        std::fs::write(d.join(format!("{name}.citypvs-checkpoint")), bytes).unwrap();
        let out = run(d, &["bake", "city.geojson", "-o", name, "-q", "--json"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let lines: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("checkpoint"))
            .collect();
        assert_eq!(lines.len(), 1, "{stderr}");
        assert!(
            lines[0].contains("ignoring checkpoint")
                && lines[0].contains("starting over")
                && lines[0].contains(needle),
            "{stderr}"
        );
        assert_eq!(json(&out)["cells_from_checkpoint"], 0);
        assert!(std::fs::read(d.join(name)).unwrap() == std::fs::read(d.join("full.pvs")).unwrap());
        assert!(!d.join(format!("{name}.citypvs-checkpoint")).exists());
    }
}
