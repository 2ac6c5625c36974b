//! The bake: a prepared scene's cells get their visible sets from the
//! visibility engine, streamed in cell order to a sink (the file writer, a
//! shard, a checkpoint), with the statistics the `bake` command prints.

use std::ops::Range;
use std::time::Instant;

use crate::Result;
use crate::prepare::{Scene, StageTime};
use crate::pvs::{BakeInfo, PvsData};
use crate::visibility::{SolveStats, VisibilityEngine};

/// Statistics of one bake.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BakeStats {
    pub cells: usize,
    pub samples: usize,
    pub objects: usize,
    pub mean_visible: f64,
    pub max_visible: usize,
    /// Fraction of (cell, object) pairs left out of the PVS.
    pub culled_fraction: f64,
    /// The most unit (vertex or edge) visible sets held at once.
    pub peak_sets_held: usize,
}

/// Running totals of the sets a bake hands on, turned into [`BakeStats`].
#[derive(Clone, Debug, Default)]
pub struct SetTally {
    cells: usize,
    total: usize,
    max: usize,
}

impl SetTally {
    /// Count one cell's set.
    pub fn add(&mut self, set: &[u32]) {
        self.add_len(set.len());
    }

    /// Count one more set, of `len` objects.
    pub fn add_len(&mut self, len: usize) {
        self.cells += 1;
        self.total += len;
        self.max = self.max.max(len);
    }

    /// The statistics of the sets counted.
    pub fn stats(&self, objects: usize, solve: &SolveStats) -> BakeStats {
        BakeStats {
            cells: self.cells,
            samples: solve.samples,
            objects,
            mean_visible: if self.cells > 0 {
                self.total as f64 / self.cells as f64
            } else {
                0.0
            },
            max_visible: self.max,
            culled_fraction: if self.cells > 0 && objects > 0 {
                1.0 - self.total as f64 / (self.cells as f64 * objects as f64)
            } else {
                0.0
            },
            peak_sets_held: solve.peak_units_held,
        }
    }
}

/// The header of a bake of `scene`.
pub fn bake_info(scene: &Scene) -> BakeInfo {
    let s = &scene.settings;
    BakeInfo {
        numbers: *s.numbers(),
        frame: scene.city.frame.clone(),
        source_hash: scene.city.source_hash,
        region_hash: s.region_hash(),
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
    }
}

/// Solve the cells in `range` and hand each set to `sink` in cell order.
pub fn bake_cells(
    engine: &VisibilityEngine,
    objects: usize,
    range: Range<usize>,
    progress: &(dyn Fn(u64) + Sync),
    mut sink: impl FnMut(usize, &[u32]) -> Result<()>,
) -> Result<(BakeStats, StageTime)> {
    let t = Instant::now();
    let mut tally = SetTally::default();
    let solve = engine.solve_cells(range, progress, |cell, set| {
        tally.add(&set);
        sink(cell, &set)
    })?;
    let timing = StageTime {
        stage: "visibility",
        seconds: t.elapsed().as_secs_f64(),
    };
    Ok((tally.stats(objects, &solve), timing))
}

/// Compute every cell's PVS and package it with the bake parameters.
pub fn bake(
    scene: &Scene,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(PvsData, BakeStats, StageTime)> {
    let engine = VisibilityEngine::new(scene)?;
    let mut visible = Vec::with_capacity(scene.cells.triangles.len());
    let (stats, timing) = bake_cells(
        &engine,
        scene.city.buildings.len(),
        0..scene.cells.triangles.len(),
        progress,
        |_, set| {
            visible.push(set.to_vec());
            Ok(())
        },
    )?;
    let data = PvsData {
        info: bake_info(scene),
        object_ids: scene.city.buildings.iter().map(|b| b.id.clone()).collect(),
        object_prints: crate::pvs::prints::object_prints(scene),
        cells: scene.cells.triangles.clone(),
        visible,
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

/// CPU seconds (user and system, every thread) this process has used so
/// far, where the OS tells it: the difference over a stretch of work is
/// the work's CPU time.
pub fn cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
        // SAFETY: `getrusage` writes a `rusage` into the pointer it is given
        // and reads nothing else; the struct is zero-initialised first.
        let status = unsafe { libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) };
        if status != 0 {
            return None;
        }
        // SAFETY: zero bits are a valid `rusage`, and the call succeeded.
        let usage = unsafe { usage.assume_init() };
        let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Peak resident memory of this process in bytes, where the OS tells it.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
