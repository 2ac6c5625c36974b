//! The independent judge: dense point sampling of each chosen cell and exact
//! point-to-building visibility against the original, unshrunk buildings
//! (METHOD.md 7). Shares no code with the bake's shadow path.
//!
//! OWNER: verify helper. The types and functions below are the agreed interface.

use glam::DVec2;

use crate::model::Building;

/// Which cells to check and how densely.
#[derive(Clone, Debug)]
pub struct VerifyOptions {
    /// `None` = every cell; `Some(k)` = k cells drawn at random.
    pub cells: Option<usize>,
    /// Viewpoints per cell.
    pub samples: usize,
    pub seed: u64,
}

/// One building seen from a viewpoint of a cell whose PVS leaves it out.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Violation {
    pub cell: usize,
    pub building: String,
    pub viewpoint: [f64; 3],
    pub witness: [f64; 3],
}

/// What the judge found.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct VerifyReport {
    pub cells_checked: usize,
    pub viewpoints: usize,
    pub violations: Vec<Violation>,
    /// Mean over cells of |PVS| / max(1, |seen|).
    pub mean_tightness: f64,
    /// Worst (largest) such ratio.
    pub worst_tightness: f64,
    /// Fraction of PVS entries that some viewpoint saw.
    pub seen_fraction: f64,
    pub seconds: f64,
}

/// Judge the visible sets `visible[c]` (ascending building indices) of the
/// cells `cells[c]` (prisms from z = 0 to `eye_height`).
pub fn verify(
    _buildings: &[Building],
    _cells: &[[DVec2; 3]],
    _eye_height: f64,
    _visible: &[Vec<u32>],
    _options: &VerifyOptions,
) -> VerifyReport {
    todo!("verify helper")
}
