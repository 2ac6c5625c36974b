//! Timings of merge, erosion and triangulation on generated cities. Ignored
//! by default; run with
//! `cargo test --release --test geometry geometry_timing:: -- --ignored --nocapture`.

use std::time::Instant;

use crate::common::generated_buildings;
use citypvs::cells::{CellParams, triangulate};
use citypvs::generate::Style;
use citypvs::geometry::{merge_blocks, shrink_blocks};
use citypvs::model::Building;
use glam::DVec2;
use std::collections::BTreeSet;

fn city(n: usize) -> Vec<Building> {
    generated_buildings(n, 1, Style::Default)
}

/// The number and total length of the distinct cell edges (the visibility
/// stage samples every distinct edge once).
fn distinct_edges(triangles: &[[DVec2; 3]]) -> (usize, f64) {
    let key = |p: DVec2| (p.x.to_bits(), p.y.to_bits());
    let mut edges = BTreeSet::new();
    for t in triangles {
        for i in 0..3 {
            let (a, b) = (key(t[i]), key(t[(i + 1) % 3]));
            edges.insert((a.min(b), a.max(b)));
        }
    }
    let point = |k: (u64, u64)| DVec2::new(f64::from_bits(k.0), f64::from_bits(k.1));
    let length = edges
        .iter()
        .map(|&(a, b)| point(a).distance(point(b)))
        .sum();
    (edges.len(), length)
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
    let level_vertices: usize = blocks
        .iter()
        .flat_map(|b| b.levels.iter().flat_map(|l| l.area.iter()))
        .map(|p| p.exterior.len() + p.holes.iter().map(Vec::len).sum::<usize>())
        .sum();
    let (edges, edge_length) = distinct_edges(&cells.triangles);
    let occluder_vertices: usize = occluders
        .iter()
        .flat_map(|o| o.shape.iter())
        .map(|p| p.exterior.len() + p.holes.iter().map(Vec::len).sum::<usize>())
        .sum();
    println!(
        "{n} buildings: {} blocks, {levels} levels ({level_vertices} vertices), {} occluders ({occluder_vertices} vertices), {} cells ({edges} edges, {edge_length:.0} m); \
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

#[test]
#[ignore]
fn timing_large_generated_city() {
    time_city(100_000);
}
