//! Many tiny buildings that all erode to nothing: every cell sees every
//! building. The bake must hold its sets compactly (runs or bitsets), not
//! as cells x buildings lists: 1,000 such buildings make about 10,800 cells,
//! whose sets as lists would take 43 MB.

#[test]
fn every_cell_seeing_every_building_keeps_memory_small() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tiny.geojson"),
        crate::common::tiny_city(1000),
    )
    .unwrap();
    let summary = crate::common::citypvs_json(
        dir.path(),
        &[
            "bake",
            "tiny.geojson",
            "--metric",
            "--min-gap",
            "0",
            "-q",
            "-o",
            "tiny.pvs",
        ],
    );
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
