//! Cell-to-object visibility: samples on each cell's top edges, software cull
//! maps of the shrunk occluders' shadows, the hierarchical horizon test, and
//! the per-cell potentially visible sets (METHOD.md 3 to 6).

use glam::{DVec2, DVec3};

use crate::prepare::Scene;

/// Default eye height in metres (a pedestrian's eyes).
pub const DEFAULT_EYE_HEIGHT: f64 = 1.7;

/// Parameters of the bake's visibility stage.
#[derive(Clone, Debug)]
pub struct VisibilityParams {
    /// Eye height h: cells are prisms from 0 to h.
    pub eye_height: f64,
    /// Cull-map pixel size k in metres; k * sqrt(2) / 2 <= eps.
    pub pixel: f64,
}

/// A cell's final cull map F (min over its samples of the max over occluder
/// shadows), for pictures and debugging.
#[derive(Clone, Debug)]
pub struct CullMapImage {
    /// Local metres of the lower-left corner of pixel (0, 0).
    pub origin: DVec2,
    /// Pixel size in metres.
    pub pixel: f64,
    pub width: usize,
    pub height: usize,
    /// Row-major shadow heights in metres; row 0 is the southernmost row
    /// (y = origin.y .. origin.y + pixel). 0 means nothing is hidden there.
    pub heights: Vec<f32>,
}

/// The sample points (x, y, eye height) of one cell's top edges.
pub fn cell_samples(_scene: &Scene, _params: &VisibilityParams, _cell: usize) -> Vec<DVec3> {
    todo!("lead")
}

/// The final cull map of one cell.
pub fn cell_cull_map(_scene: &Scene, _params: &VisibilityParams, _cell: usize) -> CullMapImage {
    todo!("lead")
}
