//! The bake judged by the independent judge: generated cities and the real
//! Kotka extract are baked at default settings and every chosen cell is
//! checked by dense point sampling; any violation fails the test.
//!
//! CI checks a sample of cells. To judge every cell, run
//! `CITYPVS_VERIFY_ALL=1 cargo test --release --test judge verify_bake:: -- --nocapture`.

use std::path::Path;

use citypvs::bake::{BakeStats, bake};
use citypvs::generate::{GenerateParams, generate_geojson};
use citypvs::input::{City, InputOptions, read_city, read_city_bytes};
use citypvs::model::Polygon;
use citypvs::prepare::prepare;
use citypvs::verify::{VerifyOptions, VerifyReport, verify};
use glam::DVec2;

/// Cells judged per city in CI (all of them with CITYPVS_VERIFY_ALL).
fn cells_to_check(default: usize) -> Option<usize> {
    match std::env::var("CITYPVS_VERIFY_ALL") {
        Ok(v) if v != "0" => None,
        _ => Some(default),
    }
}

fn bake_and_judge(
    city: City,
    name: &str,
    cells: usize,
    seed: u64,
    region: Option<Polygon>,
) -> VerifyReport {
    let settings = citypvs::Settings::new(citypvs::RawSettings {
        region,
        ..Default::default()
    })
    .expect("settings");
    let options = VerifyOptions {
        cells: cells_to_check(cells),
        samples: 64,
        seed,
    };
    let (stats, report) = bake_and_verify(city, &settings, &options);
    eprintln!(
        "{name}: {} cells, mean PVS {:.1}, culled {:.3}; judged {} cells x 64 points: {} violations, \
         tightness mean {:.2} worst {:.2}, seen fraction {:.3}, {:.1} s",
        stats.cells,
        stats.mean_visible,
        stats.culled_fraction,
        report.cells_checked,
        report.violations.len(),
        report.mean_tightness,
        report.worst_tightness,
        report.seen_fraction,
        report.seconds
    );
    assert!(report.cells_checked > 0, "{name}: no cell was judged");
    assert!(
        report.violations.is_empty(),
        "{name}: the PVS leaves out visible buildings: {:#?}",
        &report.violations[..report.violations.len().min(10)]
    );
    report
}

/// Prepare and bake `city` with `settings` through the library, and judge
/// the result.
pub fn bake_and_verify(
    city: City,
    settings: &citypvs::Settings,
    options: &VerifyOptions,
) -> (BakeStats, VerifyReport) {
    let scene = prepare(city, settings).expect("prepare");
    let (data, stats, _) = bake(&scene, &|_| {}).expect("bake");
    let report = verify(
        &scene.city.buildings,
        &data.cells,
        scene.settings.eye_height,
        &data.visible,
        options,
    );
    (stats, report)
}

#[test]
fn generated_cities_pass_the_judge() {
    for seed in 1..=3 {
        let geojson = generate_geojson(&GenerateParams {
            buildings: 150,
            seed,
        });
        let city = read_city_bytes(
            geojson.as_bytes(),
            &format!("generated-{seed}"),
            &InputOptions::default(),
        )
        .expect("read generated city");
        let report = bake_and_judge(city, &format!("generated seed {seed}"), 40, seed, None);
        // The judge must see something: a PVS that culls everything visible
        // would show up as violations, one that sees nothing as a broken judge.
        assert!(report.seen_fraction > 0.0);
    }
}

#[test]
fn kotka_passes_the_judge() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kotka.geojson");
    let city = read_city(&path, &InputOptions::default()).expect("read Kotka");
    // CI bakes the 600 m square around the densest part of the extract (the
    // whole extract has 42,000 cells; CITYPVS_VERIFY_ALL=1 judges all of it).
    // Buildings outside the square still occlude and are judged.
    let centre = densest_point(&city);
    let half = if std::env::var("CITYPVS_VERIFY_ALL").is_ok_and(|v| v != "0") {
        1e6
    } else {
        300.0
    };
    let region = (half < 1e5).then(|| Polygon {
        exterior: vec![
            centre + DVec2::new(-half, -half),
            centre + DVec2::new(half, -half),
            centre + DVec2::new(half, half),
            centre + DVec2::new(-half, half),
        ],
        holes: vec![],
    });
    bake_and_judge(city, "kotka", 40, 7, region);
}

/// The centre of the 200 m grid square holding the most building vertices.
fn densest_point(city: &City) -> DVec2 {
    let mut counts = std::collections::BTreeMap::new();
    for b in &city.buildings {
        for p in &b.footprint {
            for v in &p.exterior {
                let key = ((v.x / 200.0).floor() as i64, (v.y / 200.0).floor() as i64);
                *counts.entry(key).or_insert(0usize) += 1;
            }
        }
    }
    let (&(i, j), _) = counts
        .iter()
        .max_by_key(|&(k, c)| (*c, std::cmp::Reverse(*k)))
        .expect("buildings");
    DVec2::new((i as f64 + 0.5) * 200.0, (j as f64 + 0.5) * 200.0)
}
