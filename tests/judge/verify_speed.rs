//! Speed of the judge on a generated city (ignored by default; prints
//! figures, asserts nothing about time):
//! `cargo test --release --test judge verify_speed:: -- --ignored --nocapture`.

use crate::common::generated_buildings;
use citypvs::generate::Style;
use citypvs::model::{Building, Rect, point_in_multipolygon};
use citypvs::verify::{VerifyOptions, verify};
use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `count` small triangles (about 8 m across) in the street space of the city.
fn street_cells(city: &[Building], count: usize, seed: u64) -> Vec<[DVec2; 3]> {
    let bounds = city
        .iter()
        .flat_map(|b| b.footprint.iter().flat_map(|p| p.exterior.iter()))
        .fold(Rect::EMPTY, |mut r, p| {
            r.include(*p);
            r
        });
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut cells = Vec::new();
    while cells.len() < count {
        let c = DVec2::new(
            rng.random_range(bounds.min.x..bounds.max.x),
            rng.random_range(bounds.min.y..bounds.max.y),
        );
        let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let t = [0.0, 2.1, 4.2].map(|k: f64| c + DVec2::from_angle(a + k) * 4.0);
        let free = |p: DVec2| !city.iter().any(|b| point_in_multipolygon(p, &b.footprint));
        if t.iter().all(|&p| free(p)) && free(c) {
            cells.push(t);
        }
    }
    cells
}

#[test]
#[ignore]
fn measure_200_cells_of_a_1000_building_city() {
    let city = generated_buildings(1000, 1, Style::Default);
    let cells = street_cells(
        &city,
        std::env::var("VERIFY_SPEED_CELLS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(200),
        3,
    );
    let everything: Vec<u32> = (0..city.len() as u32).collect();
    let visible = vec![everything; cells.len()];
    let report = verify(
        &city,
        &cells,
        1.7,
        &visible,
        &VerifyOptions {
            cells: None,
            samples: 64,
            seed: 1,
        },
    );
    let seen: usize = report.cells.iter().map(|c| c.seen).sum();
    eprintln!(
        "1000 buildings, {} cells x 64 viewpoints on {} threads: {:.1} s, {} rays ({:.0} per viewpoint), {:.1} buildings seen per cell, {} viewpoints inside buildings",
        report.cells_checked,
        rayon::current_num_threads(),
        report.seconds,
        report.rays,
        report.rays as f64 / report.viewpoints as f64,
        seen as f64 / report.cells_checked as f64,
        report.blocked_viewpoints.len()
    );
    assert!(report.violations.is_empty());
    assert_eq!(report.viewpoints, cells.len() * 64);
}

#[test]
#[ignore]
fn measure_200_cells_of_kotka() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kotka.geojson");
    let city = citypvs::input::read_city(&path, &citypvs::input::InputOptions::default())
        .expect("fixtures/kotka.geojson reads");
    let cells = street_cells(&city.buildings, 200, 3);
    let everything: Vec<u32> = (0..city.buildings.len() as u32).collect();
    let visible = vec![everything; cells.len()];
    let report = verify(
        &city.buildings,
        &cells,
        1.7,
        &visible,
        &VerifyOptions {
            cells: None,
            samples: 64,
            seed: 1,
        },
    );
    let seen: usize = report.cells.iter().map(|c| c.seen).sum();
    eprintln!(
        "Kotka, {} buildings, {} cells x 64 viewpoints on {} threads: {:.1} s, {:.0} rays per viewpoint, {:.1} buildings seen per cell, {} viewpoints inside buildings",
        city.buildings.len(),
        report.cells_checked,
        rayon::current_num_threads(),
        report.seconds,
        report.rays as f64 / report.viewpoints as f64,
        seen as f64 / report.cells_checked as f64,
        report.blocked_viewpoints.len()
    );
    assert!(report.violations.is_empty());
}
