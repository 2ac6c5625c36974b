//! Occluder geometry: merging touching footprints into blocks whose levels
//! form a height field (METHOD.md 4), and conservative erosion of every level
//! by eps. Owns everything between valid buildings and shrunk occluders.
//!
//! OWNER: geometry helper. The types and functions below are the agreed
//! interface.

use crate::model::{Building, MultiPolygon};

/// A maximal group of buildings whose footprints touch or overlap.
#[derive(Clone, Debug)]
pub struct Block {
    /// Indices into the city's buildings, ascending.
    pub members: Vec<usize>,
    /// Levels by ascending height. Level 0 is the union of all member
    /// footprints (the block's ground footprint, standing to the lowest
    /// height); level j is the union of the member footprints whose height is
    /// at least `levels[j].height`.
    pub levels: Vec<Level>,
}

/// One level set of a block's height field: `area` is solid from 0 to `height`.
#[derive(Clone, Debug)]
pub struct Level {
    pub height: f64,
    pub area: MultiPolygon,
}

/// A shrunk level: lies inside the exact erosion of the level by eps.
#[derive(Clone, Debug)]
pub struct Occluder {
    /// Index of the block in the block list.
    pub block: usize,
    /// Index of the level in the block.
    pub level: usize,
    /// Height of the level in metres.
    pub height: f64,
    /// The eroded area (possibly empty if the level was thinner than 2*eps).
    pub shape: MultiPolygon,
}

/// Group the buildings (only those with `occludes == true`) into blocks.
pub fn merge_blocks(_buildings: &[Building]) -> Vec<Block> {
    todo!("geometry helper")
}

/// Erode an area by `eps`, conservatively: the result lies inside the exact
/// erosion (every point of it is inside `area` and at least `eps` from its
/// boundary).
pub fn erode(_area: &MultiPolygon, _eps: f64) -> MultiPolygon {
    todo!("geometry helper")
}

/// Erode every level of every block. Empty results are dropped.
pub fn shrink_blocks(blocks: &[Block], eps: f64) -> Vec<Occluder> {
    let mut out = Vec::new();
    for (b, block) in blocks.iter().enumerate() {
        for (l, level) in block.levels.iter().enumerate() {
            let shape = erode(&level.area, eps);
            if !shape.is_empty() {
                out.push(Occluder {
                    block: b,
                    level: l,
                    height: level.height,
                    shape,
                });
            }
        }
    }
    out
}
