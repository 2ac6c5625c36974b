//! Many tiny buildings with the default min gap: the opening of their free
//! space works tile by tile, so it adds at most a fixed amount of memory
//! per worker thread (docs/DESIGN.md, memory), not some 70 KiB per building
//! as when it ran over the whole city at once.

use std::process::Command;

/// The opening's stated working memory per thread, bytes.
const PER_THREAD: u64 = 32 << 20;

/// A metric GeoJSON city of `n` 1 m squares, 4 m apart, 5 m high.
fn tiny_city(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let features: Vec<String> = (0..n)
        .map(|k| {
            let (x, y) = ((k % side) as f64 * 4.0, (k / side) as f64 * 4.0);
            let ring: Vec<String> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
                .iter()
                .map(|(dx, dy)| format!("[{},{}]", x + dx, y + dy))
                .collect();
            format!(
                r#"{{"type":"Feature","properties":{{"id":"t{k}","height":5}},"geometry":{{"type":"Polygon","coordinates":[[{}]]}}}}"#,
                ring.join(",")
            )
        })
        .collect();
    format!(
        r#"{{"type":"FeatureCollection","features":[{}]}}"#,
        features.join(",")
    )
}

fn bake_peak(dir: &std::path::Path, min_gap: &str) -> u64 {
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .args([
            "bake",
            "tiny.geojson",
            "--metric",
            "--min-gap",
            min_gap,
            "--threads",
            "2",
            "-q",
            "--json",
            "-o",
            "tiny.pvs",
        ])
        .output()
        .expect("run citypvs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    summary["peak_memory_bytes"].as_u64().unwrap()
}

#[test]
fn opening_many_tiny_buildings_stays_within_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tiny.geojson"), tiny_city(2000)).unwrap();
    let without = bake_peak(dir.path(), "0");
    let with = bake_peak(dir.path(), "0.5");
    // Untiled, the opening alone took about 140 MB for 2,000 of them.
    assert!(
        with <= without + 2 * PER_THREAD,
        "peak {with} bytes with the opening, {without} without: more than {} per thread",
        PER_THREAD
    );
}
