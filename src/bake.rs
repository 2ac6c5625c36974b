//! The bake: a prepared scene's cells get their visible sets, and the result
//! becomes a [`PvsData`] ready to write. Times every stage and gathers the
//! statistics the `bake` command prints.

use std::time::Instant;

use crate::Result;
use crate::prepare::{Scene, StageTime};
use crate::pvs::{BakeInfo, PvsData};
use crate::visibility::{VisibilityParams, compute_pvs};

/// Statistics of one bake.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BakeStats {
    pub cells: usize,
    pub samples: usize,
    pub objects: usize,
    pub mean_visible: f64,
    pub max_visible: usize,
    /// Fraction of (cell, object) pairs left out of the PVS.
    pub culled_fraction: f64,
}

/// Compute every cell's PVS and package it with the bake parameters.
pub fn bake(
    scene: &Scene,
    params: &VisibilityParams,
    max_cell_edge: f64,
    margin: f64,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(PvsData, BakeStats, StageTime)> {
    let t = Instant::now();
    let result = compute_pvs(scene, params, progress)?;
    let timing = StageTime {
        stage: "visibility",
        seconds: t.elapsed().as_secs_f64(),
    };
    let objects = scene.city.buildings.len();
    let total: usize = result.visible.iter().map(Vec::len).sum();
    let cells = result.visible.len();
    let stats = BakeStats {
        cells,
        samples: result.samples,
        objects,
        mean_visible: if cells > 0 {
            total as f64 / cells as f64
        } else {
            0.0
        },
        max_visible: result.visible.iter().map(Vec::len).max().unwrap_or(0),
        culled_fraction: if cells > 0 && objects > 0 {
            1.0 - total as f64 / (cells as f64 * objects as f64)
        } else {
            0.0
        },
    };
    let data = PvsData {
        info: BakeInfo {
            eps: scene.eps,
            eye_height: params.eye_height,
            pixel: params.pixel,
            max_cell_edge,
            margin,
            near_field: params.near_field,
            min_gap: 0.0,
            frame: scene.city.frame.clone(),
            source_hash: scene.city.source_hash,
            region_hash: [0; 32],
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
        },
        object_ids: scene.city.buildings.iter().map(|b| b.id.clone()).collect(),
        cells: scene.cells.triangles.clone(),
        visible: result.visible,
    };
    Ok((data, stats, timing))
}

/// One representative point per object (the centre of its footprint's
/// bounding box), for the file's spatial numbering of objects.
pub fn object_points(scene: &Scene) -> Vec<glam::DVec2> {
    scene
        .city
        .buildings
        .iter()
        .map(|b| {
            let r = crate::model::multipolygon_bounds(&b.footprint);
            let c = (r.min + r.max) / 2.0;
            if c.is_finite() { c } else { glam::DVec2::ZERO }
        })
        .collect()
}

/// Peak resident memory of this process in bytes, where the OS tells it.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
