//! The C ABI reader: the reader-only static library is built here (feature
//! `capi`, no default features, its own target folder), and
//! tests/c/reader_check.c, compiled with the machine's `cc` against
//! include/citypvs.h and that library, reads a baked file; its answers must
//! match `citypvs inspect --json` (counts, ids, visible sets) and the Rust
//! reader (point lookups).

use std::path::{Path, PathBuf};
use std::process::Command;

use citypvs::pvs::PvsReader;

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().expect("command runs");
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Build the reader-only static library the way a C user would, in a
/// target folder of its own (so this test never waits on, or changes, the
/// build that runs it), and return its path.
fn build_static_library() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = Path::new(env!("CARGO_BIN_EXE_citypvs"))
        .parent()
        .unwrap()
        .parent()
        .unwrap()
        .join("capi");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    run(Command::new(cargo)
        .current_dir(root)
        .args([
            "rustc",
            "--release",
            "--lib",
            "--no-default-features",
            "--features",
            "capi",
            "--crate-type",
            "staticlib",
            "--target-dir",
        ])
        .arg(&target));
    target.join("release").join("libcitypvs.a")
}

#[test]
fn c_program_reads_a_baked_file() {
    let dir = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_citypvs");
    let city = dir.path().join("city.geojson");
    let pvs = dir.path().join("city.pvs");
    run(Command::new(bin)
        .args(["generate", "--buildings", "40", "--seed", "3", "-o"])
        .arg(&city));
    run(Command::new(bin)
        .arg("bake")
        .arg(&city)
        .arg("-o")
        .arg(&pvs)
        .args(["-q", "--threads", "1"]));
    let inspect: serde_json::Value = serde_json::from_str(&run(Command::new(bin)
        .arg("inspect")
        .arg(&pvs)
        .arg("--json")))
    .unwrap();

    // Points in the input frame: each cell's centroid.
    let reader = PvsReader::open(&pvs).unwrap();
    let frame = &reader.info().frame;
    let mut points = String::new();
    let mut expect_at = Vec::new();
    for c in 0..reader.cell_count() {
        let t = reader.cell_triangle(c);
        let centre = (t[0] + t[1] + t[2]) / 3.0;
        let (x, y) = frame.to_input(centre);
        points.push_str(&format!("{x:.17e} {y:.17e}\n"));
        expect_at.push((reader.cell_at(centre), reader.cell_at(frame.to_local(x, y))));
    }
    let points_file = dir.path().join("points.txt");
    std::fs::write(&points_file, points).unwrap();

    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = dir.path().join("reader_check");
    let lib = build_static_library();
    assert!(lib.exists(), "{} not built", lib.display());
    run(Command::new("cc")
        .arg("-std=c99")
        .arg("-Wall")
        .arg("-Werror")
        .arg("-I")
        .arg(root.join("include"))
        .arg(root.join("tests/c/reader_check.c"))
        .arg(&lib)
        .args(["-lpthread", "-ldl", "-lm", "-o"])
        .arg(&exe));
    let out = run(Command::new(&exe).arg(&pvs).arg(&points_file));

    let cells = inspect["cells"].as_array().unwrap();
    let objects = inspect["stats"]["objects"].as_u64().unwrap() as usize;
    let mut lines = out.lines();
    assert_eq!(lines.next().unwrap(), format!("cells {}", cells.len()));
    assert_eq!(lines.next().unwrap(), format!("objects {objects}"));
    let mut ids = Vec::new();
    for i in 0..objects {
        let line = lines.next().unwrap();
        let id = line.strip_prefix(&format!("id {i} ")).expect(line);
        ids.push(id.to_string());
    }
    for (c, cell) in cells.iter().enumerate() {
        let line = lines.next().unwrap();
        let mut words = line.split(' ');
        assert_eq!(words.next(), Some("cell"));
        assert_eq!(words.next(), Some(c.to_string().as_str()));
        let count: usize = words.next().unwrap().parse().unwrap();
        let visible: Vec<&str> = words
            .map(|w| ids[w.parse::<usize>().unwrap()].as_str())
            .collect();
        let expected: Vec<&str> = cell["visible"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        assert_eq!(count, expected.len());
        assert_eq!(visible, expected, "cell {c}");
    }
    let mut found_own = 0;
    for (c, (local, input)) in expect_at.iter().enumerate() {
        let line = lines.next().unwrap();
        let expected = format!(
            "at {c} {} {}",
            local.expect("centroid in a cell"),
            input.expect("centroid in a cell")
        );
        assert_eq!(line, expected);
        found_own += usize::from(*local == Some(c));
    }
    assert_eq!(found_own, cells.len(), "each centroid lies in its own cell");
    assert_eq!(lines.next(), Some("ok"));
}
