//! Many tiny buildings that all erode to nothing: every cell sees every
//! building. The bake must hold its sets compactly (runs or bitsets), not
//! as cells x buildings lists: 1,000 such buildings make about 10,800 cells,
//! whose sets as lists would take 43 MB.

use std::process::Command;

/// A metric GeoJSON city of `n` 1 m squares, 4 m apart, 5 m high.
fn tiny_city(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let mut features = Vec::new();
    for k in 0..n {
        let (x, y) = ((k % side) as f64 * 4.0, (k / side) as f64 * 4.0);
        let ring: Vec<String> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
            .iter()
            .map(|(dx, dy)| format!("[{},{}]", x + dx, y + dy))
            .collect();
        let ring = ring.join(",");
        features.push(format!(
            r#"{{"type":"Feature","properties":{{"id":"t{k}","height":5}},"geometry":{{"type":"Polygon","coordinates":[[{ring}]]}}}}"#
        ));
    }
    format!(
        r#"{{"type":"FeatureCollection","features":[{}]}}"#,
        features.join(",")
    )
}

#[test]
fn every_cell_seeing_every_building_keeps_memory_small() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tiny.geojson"), tiny_city(1000)).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir.path())
        .args([
            "bake",
            "tiny.geojson",
            "--metric",
            "--min-gap",
            "0",
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
    let cells = summary["cells"].as_u64().unwrap();
    assert!(cells > 5000, "{cells} cells");
    assert_eq!(
        summary["mean_visible"].as_f64().unwrap(),
        1000.0,
        "nothing occludes"
    );
    // Lists of every cell's set would alone take cells x 1000 x 4 bytes.
    let as_lists = cells * 1000 * 4;
    let peak = summary["peak_memory_bytes"].as_u64().unwrap();
    assert!(
        peak < as_lists * 2 / 3,
        "peak memory {peak} bytes, the sets as lists would be {as_lists}"
    );
}
