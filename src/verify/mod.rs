//! The independent judge: dense point sampling of each chosen cell and exact
//! point-to-building visibility against the original, unshrunk buildings
//! (docs/METHOD.md §7). Shares no code with the bake's shadow path.
//!
//! Submodules: [`sampling`] (which cells, which viewpoints), [`sight`]
//! (exact visibility from one point), [`edges`] (the judge's edge grid and
//! ray walk), [`envelope`] (the horizon of one wedge of rays), `beyond`
//! (how high anything stands beyond a distance in a range of directions,
//! where a walk may stop), `buckets` (sorting by a float key in about
//! linear time), and [`verify_file`] (a `.pvs` file against its
//! city: ids, frame, cells).

mod beyond;
mod buckets;
pub mod edges;
pub mod envelope;
mod file;
pub mod sampling;
pub mod sight;

use std::collections::BTreeMap;
use std::time::Instant;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::model::Building;
pub use file::{FileCheck, FileUnderTest, verify_file};
pub use sampling::{LOWEST_VIEWPOINT, cell_viewpoints, choose_cells};
pub use sight::{Judge, Scratch, Sighting, View};

/// Cells checked when no count is given.
pub const DEFAULT_CELLS: usize = 200;
/// Viewpoints per cell when no count is given.
pub const DEFAULT_SAMPLES: usize = 64;
/// Seed used when none is given.
pub const DEFAULT_SEED: u64 = 1;
/// Viewpoints judged (and held in memory) at a time.
const VIEWPOINTS_PER_BATCH: usize = 8192;

/// Which cells to check and how densely.
#[derive(Clone, Debug)]
pub struct VerifyOptions {
    /// `None` = every cell; `Some(k)` = k cells drawn at random.
    pub cells: Option<usize>,
    /// Viewpoints per cell.
    pub samples: usize,
    pub seed: u64,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        VerifyOptions {
            cells: Some(DEFAULT_CELLS),
            samples: DEFAULT_SAMPLES,
            seed: DEFAULT_SEED,
        }
    }
}

/// One building seen from a viewpoint of a cell whose PVS leaves it out.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Violation {
    pub cell: usize,
    pub building: String,
    pub viewpoint: [f64; 3],
    pub witness: [f64; 3],
    /// The viewpoint's x, y in the input file's coordinates, when the frame
    /// is known ([`verify_file`] fills it in).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub viewpoint_input: Option<[f64; 2]>,
    /// The witness's x, y in the input file's coordinates, likewise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub witness_input: Option<[f64; 2]>,
}

/// A viewpoint the judge could not use: it lies inside an occluding building
/// (the cell overlaps a footprint).
#[derive(Clone, Debug, serde::Serialize)]
pub struct BlockedViewpoint {
    pub cell: usize,
    pub building: String,
    pub viewpoint: [f64; 3],
    /// Distance from the viewpoint to the building's outline (metres).
    pub depth: f64,
}

/// The judge's figures for one cell.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CellVerdict {
    pub cell: usize,
    /// |PVS| of the cell.
    pub pvs: usize,
    /// Buildings seen by some viewpoint of the cell.
    pub seen: usize,
    /// Buildings seen but missing from the PVS.
    pub missing: usize,
    /// |PVS| / max(1, seen).
    pub tightness: f64,
}

/// What the judge found.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct VerifyReport {
    pub cells_checked: usize,
    /// Cells in the PVS.
    pub cells_total: usize,
    pub viewpoints: usize,
    pub samples_per_cell: usize,
    pub seed: u64,
    pub eye_height: f64,
    pub violations: Vec<Violation>,
    /// Viewpoints inside occluding buildings (not judged).
    pub blocked_viewpoints: Vec<BlockedViewpoint>,
    /// Mean over cells of |PVS| / max(1, |seen|).
    pub mean_tightness: f64,
    /// Worst (largest) such ratio.
    pub worst_tightness: f64,
    /// Fraction of PVS entries that some viewpoint saw.
    pub seen_fraction: f64,
    /// Rays walked (one per wedge of directions per viewpoint).
    pub rays: u64,
    pub seconds: f64,
    /// Per checked cell, ascending by cell index.
    pub cells: Vec<CellVerdict>,
}

impl VerifyReport {
    /// Viewpoints judged (those not inside a building).
    pub fn judged_viewpoints(&self) -> usize {
        self.viewpoints - self.blocked_viewpoints.len()
    }

    /// A pass: no violation, and something was judged (at least one cell,
    /// one viewpoint outside the buildings, at a real eye height). Checking
    /// nothing is never a pass.
    pub fn passed(&self) -> bool {
        self.violations.is_empty()
            && self.cells_checked > 0
            && self.judged_viewpoints() > 0
            && self.eye_height > 0.0
            && self.eye_height.is_finite()
    }
}

/// Judge the visible sets `visible[c]` (ascending building indices) of the
/// cells `cells[c]` (prisms from z = 0 to `eye_height`).
pub fn verify(
    buildings: &[Building],
    cells: &[[DVec2; 3]],
    eye_height: f64,
    visible: &[Vec<u32>],
    options: &VerifyOptions,
) -> VerifyReport {
    verify_with_progress(buildings, cells, eye_height, visible, options, &|_| {})
}

/// [`verify`], calling `progress(n)` as `n` more viewpoints are done (from
/// any thread).
pub fn verify_with_progress(
    buildings: &[Building],
    cells: &[[DVec2; 3]],
    eye_height: f64,
    visible: &[Vec<u32>],
    options: &VerifyOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> VerifyReport {
    let started = Instant::now();
    let chosen = choose_cells(cells.len(), options.cells, options.seed);
    let judge = Judge::new(buildings);
    let mut report = VerifyReport {
        cells_checked: chosen.len(),
        cells_total: cells.len(),
        samples_per_cell: options.samples,
        seed: options.seed,
        eye_height,
        ..VerifyReport::default()
    };
    let (mut pvs_entries, mut pvs_entries_seen) = (0usize, 0usize);
    // Cells go in batches so that memory stays bounded for `--all`.
    let batch = (VIEWPOINTS_PER_BATCH / options.samples.max(1)).max(1);
    for group in chosen.chunks(batch) {
        let jobs: Vec<(usize, DVec3)> = group
            .iter()
            .flat_map(|&c| {
                cell_viewpoints(&cells[c], eye_height, options.samples, options.seed, c)
                    .into_iter()
                    .map(move |p| (c, p))
            })
            .collect();
        let views: Vec<View> = jobs
            .par_iter()
            .map_init(Scratch::default, |scratch, &(_, p)| {
                let view = judge.view(p, scratch);
                progress(1);
                view
            })
            .collect();
        report.viewpoints += jobs.len();
        let mut next = 0;
        for &c in group {
            // First viewpoint (in sampling order) that saw each building.
            let mut seen: BTreeMap<u32, (DVec3, DVec3)> = BTreeMap::new();
            while next < jobs.len() && jobs[next].0 == c {
                let p = jobs[next].1;
                match &views[next] {
                    View::Seen {
                        from,
                        sightings,
                        rays,
                    } => {
                        report.rays += rays;
                        for s in sightings {
                            seen.entry(s.building).or_insert((*from, s.witness));
                        }
                    }
                    View::InsideBuilding { building, depth } => {
                        report.blocked_viewpoints.push(BlockedViewpoint {
                            cell: c,
                            building: buildings[*building as usize].id.clone(),
                            viewpoint: p.to_array(),
                            depth: *depth,
                        })
                    }
                }
                next += 1;
            }
            let pvs = visible.get(c).map_or(&[][..], |v| &v[..]);
            let mut missing = 0;
            for (&b, &(p, w)) in &seen {
                if pvs.binary_search(&b).is_err() {
                    missing += 1;
                    report.violations.push(Violation {
                        cell: c,
                        building: buildings[b as usize].id.clone(),
                        viewpoint: p.to_array(),
                        witness: w.to_array(),
                        viewpoint_input: None,
                        witness_input: None,
                    });
                }
            }
            pvs_entries += pvs.len();
            pvs_entries_seen += seen.len() - missing;
            let tightness = pvs.len() as f64 / seen.len().max(1) as f64;
            report.mean_tightness += tightness;
            report.worst_tightness = report.worst_tightness.max(tightness);
            report.cells.push(CellVerdict {
                cell: c,
                pvs: pvs.len(),
                seen: seen.len(),
                missing,
                tightness,
            });
        }
    }
    if !chosen.is_empty() {
        report.mean_tightness /= chosen.len() as f64;
    }
    report.seen_fraction = if pvs_entries > 0 {
        pvs_entries_seen as f64 / pvs_entries as f64
    } else {
        1.0
    };
    report.seconds = started.elapsed().as_secs_f64();
    report
}
