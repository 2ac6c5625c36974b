//! Fuzz target: a small city through the whole front half of the pipeline
//! (merge, shrink, triangulate, the min-gap opening, cells), the
//! visibility of its first cells, and the judge on those cells. Any input
//! must give a result or an error, never a panic, an abort or a hang; and
//! the judge must find no building seen from a viewpoint of a solved cell
//! that the cell's set leaves out (a violation panics, so the fuzzer
//! keeps the input).
//!
//! The input is a GeoJSON file after one byte: bit 0 reads it in metres
//! (else lon/lat), bits 1-2 pick eps (1, 0.3, 2.5 or 0.75 m), bits 3-4
//! `--min-gap` (0.5, 0, 2 or 0.05 m), bit 5 `--max-cell-edge` 30 or 7 m,
//! bit 6 `--eye-height` 1.7 or 25 m, bit 7 `--near-field` 48 or 6 m. The
//! cells solved and judged are the first, the middle and the last.
//! Cities wider than 400 m are passed over: the target looks for geometry
//! that breaks a stage, not for the time a large city takes.
#![no_main]

use citypvs::input::{Format, InputOptions, read_city_bytes};
use citypvs::prepare::prepare;
use citypvs::settings::{RawSettings, Settings};
use citypvs::verify::{VerifyOptions, verify};
use citypvs::visibility::VisibilityEngine;
use libfuzzer_sys::fuzz_target;

/// The widest city the target bakes, in metres.
const MAX_WIDTH: f64 = 400.0;

fuzz_target!(|data: &[u8]| {
    let Some((&flags, bytes)) = data.split_first() else {
        return;
    };
    let options = InputOptions {
        metric: flags & 1 != 0,
        format: Some(Format::Geojson),
        ..InputOptions::default()
    };
    let Ok(city) = read_city_bytes(bytes, "fuzz.geojson", &options) else {
        return;
    };
    let (mut lo, mut hi) = (
        glam::DVec2::splat(f64::INFINITY),
        glam::DVec2::splat(f64::NEG_INFINITY),
    );
    for b in &city.buildings {
        for polygon in &b.footprint {
            for &p in polygon
                .exterior
                .iter()
                .chain(polygon.holes.iter().flatten())
            {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    if !((hi - lo).max_element() <= MAX_WIDTH) {
        return;
    }
    let raw = RawSettings {
        eps: Some([1.0, 0.3, 2.5, 0.75][usize::from(flags >> 1 & 3)]),
        min_gap: Some([0.5, 0.0, 2.0, 0.05][usize::from(flags >> 3 & 3)]),
        max_cell_edge: Some(if flags & 32 == 0 { 30.0 } else { 7.0 }),
        eye_height: Some(if flags & 64 == 0 { 1.7 } else { 25.0 }),
        near_field: Some(if flags & 128 == 0 { 48.0 } else { 6.0 }),
        margin: Some(5.0),
        ..RawSettings::default()
    };
    let Ok(settings) = Settings::new(raw) else {
        return;
    };
    let Ok(scene) = prepare(city, &settings) else {
        return;
    };
    let Ok(engine) = VisibilityEngine::new(&scene) else {
        return;
    };
    let count = engine.cell_count();
    if count == 0 {
        return;
    }
    let mut chosen = vec![0, count / 2, count - 1];
    chosen.dedup();
    let mut sets = Vec::new();
    for &cell in &chosen {
        if engine
            .solve_cells(cell..cell + 1, &|_| {}, |_, set| {
                sets.push(set);
                Ok(())
            })
            .is_err()
        {
            return;
        }
    }
    let triangles: Vec<_> = chosen.iter().map(|&c| scene.cells.triangles[c]).collect();
    let options = VerifyOptions {
        cells: None,
        samples: 16,
        seed: u64::from(flags),
    };
    let report = verify(
        &scene.city.buildings,
        &triangles,
        scene.settings.eye_height,
        &sets,
        &options,
    );
    if let Some(v) = report.violations.first() {
        panic!(
            "{} violations; the first: cell {} leaves out {} seen from {:?} at {:?}",
            report.violations.len(),
            chosen[v.cell],
            v.building,
            v.viewpoint,
            v.witness
        );
    }
});
