//! Timings of merge, erosion and triangulation on generated cities. Ignored
//! by default; run with
//! `cargo test --release --test geometry_timing -- --ignored --nocapture`.

use std::time::Instant;

use citypvs::cells::{CellParams, triangulate};
use citypvs::generate::{GenerateParams, generate_buildings};
use citypvs::geometry::{merge_blocks, shrink_blocks};
use citypvs::model::Building;

fn city(n: usize) -> Vec<Building> {
    generate_buildings(&GenerateParams {
        buildings: n,
        seed: 1,
    })
    .into_iter()
    .map(|b| Building {
        id: b.id,
        footprint: vec![b.footprint],
        height: b.height,
        occludes: true,
    })
    .collect()
}

fn time_city(n: usize) {
    let buildings = city(n);
    let t = Instant::now();
    let blocks = merge_blocks(&buildings);
    let merge = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let occluders = shrink_blocks(&blocks, 1.0);
    let erode = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let cells = triangulate(&blocks, &CellParams::default()).unwrap();
    let cells_time = t.elapsed().as_secs_f64();
    let levels: usize = blocks.iter().map(|b| b.levels.len()).sum();
    println!(
        "{n} buildings: {} blocks, {levels} levels, {} occluders, {} cells; \
         merge {merge:.3} s, erode {erode:.3} s, triangulate {cells_time:.3} s, total {:.3} s",
        blocks.len(),
        occluders.len(),
        cells.triangles.len(),
        merge + erode + cells_time
    );
}

#[test]
#[ignore]
fn timing_generated_cities() {
    for n in [1_000, 10_000] {
        time_city(n);
    }
}
