//! Measurements behind docs/FORMAT.md's table: convert a version 1 file (the
//! same visible sets) to version 2 under several block sizes and object
//! numberings and time the reader. Ignored by default (it needs baked files):
//!
//! CITYPVS_V1=city.v1.pvs [CITYPVS_CITY=city.geojson] [CITYPVS_OUT=city.pvs]
//! cargo test --release --test format pvs_v2_measure:: -- --ignored --nocapture
//!
//! or CITYPVS_V2=city.pvs (a file this citypvs reads) instead of CITYPVS_V1.

use std::time::Instant;

use citypvs::input::{InputOptions, read_city};
use citypvs::pvs::v1::read_v1;
use citypvs::pvs::{PvsData, PvsReader, PvsWriter, points_from_sets};
use glam::DVec2;

fn encode(
    data: &PvsData,
    points: &[DVec2],
    block: u32,
) -> (Vec<u8>, citypvs::pvs::WriteStats, [u64; 3]) {
    let mut w = PvsWriter::with_block_cells(
        data.info.clone(),
        data.object_ids.clone(),
        points.to_vec(),
        data.cells.clone(),
        block,
    )
    .unwrap();
    for s in &data.visible {
        w.push_cell(s).unwrap();
    }
    let modes = w.coding_counts();
    let (bytes, stats) = w.finish().unwrap();
    (bytes, stats, modes)
}

#[test]
#[ignore]
fn convert_and_measure() {
    let (v1, mut data, raw) = if let Ok(v2) = std::env::var("CITYPVS_V2") {
        let reader = PvsReader::open(v2.as_ref()).unwrap();
        let data = reader.to_data().unwrap();
        let raw = citypvs::pvs::v1::write_v1(&data);
        (v2, data, raw)
    } else if let Ok(v1) = std::env::var("CITYPVS_V1") {
        let raw = std::fs::read(&v1).unwrap();
        (v1, read_v1(&raw).unwrap(), raw)
    } else {
        eprintln!("set CITYPVS_V1 to a version 1 .pvs file or CITYPVS_V2 to a version 2 one");
        return;
    };
    if let Ok(out) = std::env::var("CITYPVS_V1_OUT") {
        std::fs::write(&out, &raw).unwrap();
    }
    if data.info.numbers.near_field == 0.0 {
        // Version 1 did not store it; any valid value codes the same sets.
        data.info.numbers.near_field = citypvs::settings::DEFAULT_NEAR_FIELD;
    }
    let n = data.object_ids.len();
    let cells = data.cells.len();
    let total: usize = data.visible.iter().map(Vec::len).sum();
    println!(
        "{v1}: {cells} cells, {n} objects, mean visible {:.1}, v1 file {} bytes",
        total as f64 / cells as f64,
        raw.len()
    );
    let mut numberings: Vec<(&str, Vec<DVec2>)> = vec![
        (
            "input order",
            (0..n).map(|i| DVec2::new(i as f64, 0.0)).collect(),
        ),
        ("from sets", points_from_sets(&data)),
    ];
    if let Ok(city) = std::env::var("CITYPVS_CITY") {
        let city = read_city(city.as_ref(), &InputOptions::default()).unwrap();
        let by_id: std::collections::HashMap<&str, DVec2> = city
            .buildings
            .iter()
            .map(|b| {
                let r = citypvs::model::multipolygon_bounds(&b.footprint);
                (b.id.as_str(), (r.min + r.max) / 2.0)
            })
            .collect();
        numberings.push((
            "footprint centres",
            data.object_ids
                .iter()
                .map(|id| by_id[id.as_str()])
                .collect(),
        ));
    }
    // CITYPVS_BLOCKS=16,64 and CITYPVS_NUMBERINGS=footprint limit the runs.
    let blocks: Vec<u32> = std::env::var("CITYPVS_BLOCKS")
        .map(|v| v.split(',').map(|b| b.parse().unwrap()).collect())
        .unwrap_or_else(|_| vec![1, 8, 16, 32, 64, 128]);
    if let Ok(keep) = std::env::var("CITYPVS_NUMBERINGS") {
        numberings.retain(|(name, _)| keep.split(',').any(|k| name.starts_with(k)));
    }
    let mut best: Option<(usize, Vec<u8>)> = None;
    for (name, points) in &numberings {
        for &block in &blocks {
            let (bytes, stats, modes) = encode(&data, points, block);
            println!(
                "  {name:18} block {block:4}: file {:9} (objects {}, mesh {}, blocks {}), raw {} ({:.1}x), quake {}, modes {modes:?}",
                bytes.len(),
                stats.object_bytes,
                stats.mesh_bytes,
                stats.record_bytes,
                stats.raw_bitset_bytes,
                stats.raw_bitset_bytes as f64 / bytes.len() as f64,
                stats.rle_bitset_bytes
            );
            if block == citypvs::pvs::BLOCK_CELLS
                && best.as_ref().is_none_or(|(l, _)| bytes.len() < *l)
            {
                best = Some((bytes.len(), bytes));
            }
        }
    }
    let bytes = best.unwrap().1;
    // Check the round trip and time the reader.
    let t = Instant::now();
    let reader = PvsReader::from_bytes(bytes.clone()).unwrap();
    let open = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut count = 0;
    reader
        .for_each_visible(|c, set| {
            assert_eq!(set, data.visible[c].as_slice(), "cell {c}");
            count += set.len();
            Ok(())
        })
        .unwrap();
    let all = t.elapsed().as_secs_f64();
    assert_eq!(count, total);
    let picks: Vec<usize> = (0..2000).map(|k| (k * 7919) % cells).collect();
    let t = Instant::now();
    for &c in &picks {
        assert_eq!(reader.visible(c).unwrap().len(), data.visible[c].len());
    }
    let one = t.elapsed().as_secs_f64() / picks.len() as f64;
    for c in (0..cells).step_by(97) {
        let t = data.cells[c];
        for p in [t[0], (t[0] + t[1]) / 2.0, (t[0] + t[1] + t[2]) / 3.0] {
            let lowest = (0..cells).find(|&k| citypvs::pvs::triangle_contains(&data.cells[k], p));
            assert_eq!(reader.cell_at(p), lowest);
        }
    }
    println!(
        "  reader: open {:.4} s, one cell {:.1} us, every cell {:.4} s",
        open,
        one * 1e6,
        all
    );
    if let Ok(out) = std::env::var("CITYPVS_OUT") {
        std::fs::write(&out, &bytes).unwrap();
        println!("  wrote {out}");
    }
}
