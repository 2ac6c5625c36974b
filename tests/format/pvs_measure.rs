//! Measures the visible-set codings on synthetic but city-like data: 10,000
//! cells over 1,000 objects, each cell seeing a spatially coherent 3-15% of
//! the objects. Run with `cargo test --test format pvs_measure:: -- --nocapture` to see
//! the bytes per cell of each scheme (the figures quoted in docs/FORMAT.md).

use citypvs::pvs::codec::{SchemeSizes, measure};
use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SIDE: f64 = 2000.0;
const OBJECTS: usize = 1000;
const CELLS_PER_SIDE: usize = 100;

/// Object centres, and per cell the ascending visible object indices.
fn city(seed: u64) -> (Vec<DVec2>, Vec<DVec2>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let objects = (0..OBJECTS)
        .map(|_| DVec2::new(rng.random_range(0.0..SIDE), rng.random_range(0.0..SIDE)))
        .collect();
    let step = SIDE / CELLS_PER_SIDE as f64;
    let cells = (0..CELLS_PER_SIDE * CELLS_PER_SIDE)
        .map(|k| {
            DVec2::new(
                (k % CELLS_PER_SIDE) as f64 * step + step / 2.0,
                (k / CELLS_PER_SIDE) as f64 * step + step / 2.0,
            )
        })
        .collect();
    (objects, cells)
}

/// What a cell sees: objects within a view radius that varies smoothly over
/// the city (open squares see far, narrow lanes near), plus objects down the
/// street canyons through the cell (a 30 m band in x or y, up to 900 m).
fn visible_sets(objects: &[DVec2], cells: &[DVec2], order: &[u32], reach: f64) -> Vec<Vec<u32>> {
    cells
        .iter()
        .map(|c| {
            let radius =
                reach * (0.6 + 1.0 * (0.5 + 0.5 * (c.x / 310.0).sin() * (c.y / 370.0).cos()));
            let mut set: Vec<u32> = objects
                .iter()
                .enumerate()
                .filter(|(_, o)| {
                    let d = **o - *c;
                    d.length() < radius
                        || (d.x.abs() < 15.0 && d.y.abs() < 900.0)
                        || (d.y.abs() < 15.0 && d.x.abs() < 900.0)
                })
                .map(|(i, _)| order[i])
                .collect();
            set.sort_unstable();
            set
        })
        .collect()
}

/// Morton (Z-order) key of a point in the city square, 16 bits per axis.
fn morton(p: DVec2) -> u64 {
    let q = |v: f64| ((v / SIDE * 65535.0) as u64).min(65535);
    let (x, y) = (q(p.x), q(p.y));
    (0..16).fold(0, |k, b| {
        k | ((x >> b) & 1) << (2 * b) | ((y >> b) & 1) << (2 * b + 1)
    })
}

fn report(name: &str, sets: &[Vec<u32>]) -> SchemeSizes {
    let s = measure(sets.iter().map(|v| v.as_slice()), OBJECTS);
    let n = sets.len() as f64;
    let mean = sets.iter().map(|v| v.len()).sum::<usize>() as f64 / n;
    println!(
        "{name}: {} cells, {OBJECTS} objects, mean visible {mean:.1} ({:.1}%), bytes per cell: \
         raw bitset {:.1}, quake zero-rle {:.1}, gap varints {:.1}, run varints {:.1}, \
         chosen per record {:.1} (tags gaps/bitset/zero-rle/runs: {:?})",
        sets.len(),
        100.0 * mean / OBJECTS as f64,
        s.raw_bitset as f64 / n,
        s.quake_rle as f64 / n,
        s.gaps as f64 / n,
        s.runs as f64 / n,
        s.chosen as f64 / n,
        s.tag_counts
    );
    s
}

#[test]
fn coding_sizes_on_a_city_like_pvs() {
    let (objects, cells) = city(42);
    // Input order unrelated to position (as OSM ids mostly are).
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut shuffled: Vec<u32> = (0..OBJECTS as u32).collect();
    for i in (1..shuffled.len()).rev() {
        shuffled.swap(i, rng.random_range(0..=i));
    }
    // Objects numbered along a Z-order curve.
    let mut by_morton: Vec<usize> = (0..OBJECTS).collect();
    by_morton.sort_by_key(|&i| morton(objects[i]));
    let mut spatial = vec![0u32; OBJECTS];
    for (rank, &i) in by_morton.iter().enumerate() {
        spatial[i] = rank as u32;
    }

    for (name, order, reach) in [
        ("near, input order", &shuffled, 200.0),
        ("near, z-order", &spatial, 200.0),
        ("far, input order", &shuffled, 380.0),
        ("far, z-order", &spatial, 380.0),
    ] {
        let sets = visible_sets(&objects, &cells, order, reach);
        let fraction =
            sets.iter().map(|v| v.len()).sum::<usize>() as f64 / (sets.len() * OBJECTS) as f64;
        assert!(
            (0.03..=0.15).contains(&fraction),
            "mean visible fraction {fraction}"
        );
        let s = report(name, &sets);
        let cells = sets.len() as u64;
        // The chosen coding is never worse than any single one plus its tag byte.
        for single in [s.raw_bitset, s.gaps, s.runs] {
            assert!(s.chosen <= single + cells);
        }
        assert!(s.chosen < s.quake_rle);
    }
}

/// Timing on a larger file: `cargo test --test format pvs_measure:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn write_and_open_timing_on_a_large_file() {
    use citypvs::input::Frame;
    use citypvs::pvs::{BakeInfo, PvsData, PvsReader, write_pvs};
    use std::time::Instant;
    let (cells_n, objects_n) = (50_000usize, 10_000usize);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let visible: Vec<Vec<u32>> = (0..cells_n)
        .map(|c| {
            // A z-ordered-like coherent window of about 5% plus 1% scattered.
            let start = (c * objects_n / cells_n) as u32;
            let mut s: Vec<u32> = (start..start + 500)
                .filter(|&i| (i as usize) < objects_n && rng.random_bool(0.7))
                .collect();
            s.extend((0..100).map(|_| rng.random_range(0..objects_n as u32)));
            s.sort_unstable();
            s.dedup();
            s
        })
        .collect();
    let cells = (0..cells_n)
        .map(|c| {
            let p = DVec2::new((c % 500) as f64 * 10.0, (c / 500) as f64 * 10.0);
            [p, p + DVec2::new(10.0, 0.0), p + DVec2::new(0.0, 10.0)]
        })
        .collect();
    let data = PvsData {
        object_prints: Vec::new(),
        info: BakeInfo {
            numbers: crate::common::test_numbers(),
            frame: Frame::LonLat {
                lon0: 26.9,
                lat0: 60.4,
            },
            source_hash: [0; 32],
            region_hash: [0; 32],
            tool_version: "test".into(),
        },
        object_ids: (0..objects_n).map(|i| format!("way/{i}")).collect(),
        cells,
        visible,
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.pvs");
    let t = Instant::now();
    let stats = write_pvs(&path, &data).unwrap();
    let write_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let reader = PvsReader::open(&path).unwrap();
    let open_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut total = 0;
    for c in 0..reader.cell_count() {
        total += reader.visible(c).unwrap().len();
    }
    let decode_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut found = 0;
    for c in 0..reader.cell_count() {
        let tri = reader.cell_triangle(c);
        found += reader.cell_at((tri[0] + tri[1] + tri[2]) / 3.0).is_some() as usize;
    }
    let lookup_s = t.elapsed().as_secs_f64();
    assert_eq!(found, cells_n);
    println!(
        "{cells_n} cells, {objects_n} objects, {total} visible entries: file {} bytes, records {} \
         (raw {}, quake {}); write {write_s:.2} s, open {open_s:.2} s, decode all {decode_s:.2} s, \
         {cells_n} cell_at {lookup_s:.3} s",
        stats.file_bytes, stats.record_bytes, stats.raw_bitset_bytes, stats.rle_bitset_bytes
    );
}
