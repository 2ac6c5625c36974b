//! Cell-to-object visibility: samples on each cell's top edges, software cull
//! maps of the shrunk occluders' shadows, the hierarchical horizon test, and
//! the per-cell potentially visible sets (docs/METHOD.md sections 3 to 6).
//!
//! An object is in a cell's PVS iff some sample of the cell leaves it not
//! hidden (equivalently: the min over samples of the max over occluder
//! shadows, F, does not reach the object's height at some pixel it touches).
//! [`VisibilityEngine`] is the one entry point: built once per scene, it
//! solves one cell, a range of cells (streamed in cell order) or a cell's
//! cull map. Below it: [`samples`] (where the samples are), [`index`] (the
//! scene indexes), [`solver`] (one run of samples), [`cullmap`] and
//! [`horizon`] (the near and far tests), [`bitset`] (visible sets).

pub mod bitset;
pub mod cullmap;
mod engine;
pub mod horizon;
pub mod index;
pub mod samples;
pub mod solver;

pub use engine::{
    CHUNK_CELLS, CullMapImage, MAX_EXTENT, MAX_FOOTPRINT_PIXELS, MAX_PICTURE_PIXELS, SolveStats,
    VisibilityEngine, WantedObjects,
};
