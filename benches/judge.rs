//! Micro benchmark of the judge (`citypvs verify`): the time to judge one
//! viewpoint, and the rays it walks, on generated cities of several sizes,
//! from the same viewpoints in the middle 300 m square of each. Plain
//! `harness = false` (no extra dependencies): `cargo bench --bench judge`.
//! Set CITYPVS_BENCH_JUDGE_BUILDINGS (comma-separated, default
//! "1000,10000") and CITYPVS_BENCH_VIEWPOINTS (default 200).

use std::time::Instant;

use citypvs::generate::{GenerateParams, generate_geojson};
use citypvs::input::{InputOptions, read_city_bytes};
use citypvs::verify::{Judge, Scratch, View};
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Half the side of the square the viewpoints are drawn in (metres).
const HALF_SIDE: f64 = 150.0;
/// The eye height of the default bake.
const EYE: f64 = 1.7;

fn main() {
    let sizes: Vec<usize> = std::env::var("CITYPVS_BENCH_JUDGE_BUILDINGS")
        .unwrap_or_else(|_| "1000,10000".into())
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let wanted: usize = std::env::var("CITYPVS_BENCH_VIEWPOINTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200);
    println!(
        "{:>9} {:>10} {:>12} {:>10} {:>14} {:>10}",
        "buildings", "viewpoints", "judge built", "per view", "rays per view", "seen"
    );
    for buildings in sizes {
        let geojson = generate_geojson(&GenerateParams { buildings, seed: 1 });
        let city = read_city_bytes(geojson.as_bytes(), "bench", &InputOptions::default())
            .expect("read generated city");
        let t = Instant::now();
        let judge = Judge::new(&city.buildings);
        let built = t.elapsed().as_secs_f64();
        // The same random points for every city (the stream `verify` draws
        // from, seed 1; the frame puts the middle of the buildings at the
        // origin), those inside a building left out.
        let mut scratch = Scratch::default();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut points = Vec::new();
        while points.len() < wanted {
            let p = DVec3::new(
                rng.random_range(-HALF_SIDE..HALF_SIDE),
                rng.random_range(-HALF_SIDE..HALF_SIDE),
                EYE,
            );
            if matches!(judge.view(p, &mut scratch), View::Seen { .. }) {
                points.push(p);
            }
        }
        // Two rounds, the faster kept.
        let (mut best, mut rays, mut seen) = (f64::INFINITY, 0u64, 0usize);
        for _ in 0..2 {
            let t = Instant::now();
            (rays, seen) = (0, 0);
            for &p in &points {
                if let View::Seen {
                    sightings, rays: r, ..
                } = judge.view(p, &mut scratch)
                {
                    rays += r;
                    seen += sightings.len();
                }
            }
            best = best.min(t.elapsed().as_secs_f64());
        }
        let n = points.len() as f64;
        println!(
            "{buildings:>9} {:>10} {:>10.2} s {:>7.2} ms {:>14.0} {:>10.1}",
            points.len(),
            built,
            best / n * 1e3,
            rays as f64 / n,
            seen as f64 / n
        );
    }
}
