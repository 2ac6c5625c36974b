//! Many tiny buildings with the default min gap: the opening of their free
//! space works tile by tile, so it adds at most a fixed amount of memory
//! per worker thread (docs/DESIGN.md, memory), not some 70 KiB per building
//! as when it ran over the whole city at once.

/// The opening's stated working memory per thread, bytes.
const PER_THREAD: u64 = 32 << 20;

fn bake_peak(dir: &std::path::Path, min_gap: &str) -> u64 {
    let summary = crate::common::citypvs_json(
        dir,
        &[
            "bake",
            "tiny.geojson",
            "--metric",
            "--min-gap",
            min_gap,
            "--threads",
            "2",
            "-q",
            "-o",
            "tiny.pvs",
        ],
    );
    summary["peak_memory_bytes"].as_u64().unwrap()
}

#[test]
fn opening_many_tiny_buildings_stays_within_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tiny.geojson"),
        crate::common::tiny_city(2000),
    )
    .unwrap();
    let without = bake_peak(dir.path(), "0");
    let with = bake_peak(dir.path(), "0.5");
    // Untiled, the opening alone took about 140 MB for 2,000 of them.
    assert!(
        with <= without + 2 * PER_THREAD,
        "peak {with} bytes with the opening, {without} without: more than {} per thread",
        PER_THREAD
    );
}
