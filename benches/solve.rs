//! Micro benchmark of the per-sample visibility solve: the time to solve
//! one sample, and one edge's run of samples, on a generated city. Plain
//! `harness = false` (no extra dependencies): `cargo bench --bench solve`.
//! Set CITYPVS_BENCH_BUILDINGS (default 200) and CITYPVS_BENCH_EDGES
//! (default 150) to change the city and the number of edges solved.

use std::time::Instant;

use citypvs::generate::{GenerateParams, generate_geojson};
use citypvs::input::{InputOptions, read_city_bytes};
use citypvs::prepare::prepare;
use citypvs::visibility::bitset::ObjectSet;
use citypvs::visibility::index::SceneIndex;
use citypvs::visibility::samples::MeshTopology;
use citypvs::visibility::solver::Solver;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let buildings = env("CITYPVS_BENCH_BUILDINGS", 200);
    let edges = env("CITYPVS_BENCH_EDGES", 150);
    let geojson = generate_geojson(&GenerateParams { buildings, seed: 1 });
    let city = read_city_bytes(geojson.as_bytes(), "bench", &InputOptions::default())
        .expect("read generated city");
    let scene = prepare(city, &citypvs::Settings::default()).expect("prepare");
    let params = scene.settings.clone();
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = scene.city.buildings.len();
    // Edges spread over the whole city.
    let step = (topo.edges.len() / edges.max(1)).max(1);
    let runs: Vec<_> = (0..topo.edges.len())
        .step_by(step)
        .take(edges)
        .map(|e| topo.edge_interior_samples(e, scene.settings.sample_spacing()))
        .filter(|r| !r.is_empty())
        .collect();
    let samples: usize = runs.iter().map(Vec::len).sum();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    let mut visible = 0;
    // Warm up, then measure each way three times and keep the best.
    for points in runs.iter().take(5) {
        let mut set = ObjectSet::new(n);
        solver.solve_run(points, &mut set);
    }
    let mut best_single = f64::INFINITY;
    let mut best_run = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        for points in &runs {
            for &p in points {
                let mut set = ObjectSet::new(n);
                solver.solve(p, &mut set);
                visible += set.count();
            }
        }
        best_single = best_single.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for points in &runs {
            let mut set = ObjectSet::new(n);
            solver.solve_run(points, &mut set);
            visible += set.count();
        }
        best_run = best_run.min(t.elapsed().as_secs_f64());
    }
    println!(
        "{buildings}-building city, {} edges, {samples} samples (checksum {visible})",
        runs.len()
    );
    println!(
        "one sample alone:        {:8.1} us per sample",
        best_single / samples as f64 * 1e6
    );
    println!(
        "an edge's run (solve_run): {:6.1} us per sample, {:8.1} us per edge",
        best_run / samples as f64 * 1e6,
        best_run / runs.len() as f64 * 1e6
    );
}
