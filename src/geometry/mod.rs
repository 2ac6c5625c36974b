//! Occluder geometry: merging touching footprints into blocks whose levels
//! form a height field (docs/METHOD.md §4), and conservative erosion of every level
//! by eps. Owns everything between valid buildings and shrunk occluders.
//!
//! The types and functions below are the interface; the work is done in
//! `merge` (blocks and levels) and `erode` (conservative erosion), with
//! [`convert`] translating to and from `geo` for the boolean operations.

pub mod convert;
mod erode;
pub mod memo;
mod merge;

pub use erode::{EROSION_SAFETY_MARGIN, MIN_PIECE_AREA};

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

/// Group the buildings (only those with `occludes == true`) into blocks:
/// buildings whose footprints touch or overlap (exactly, no tolerance) share
/// a block. Blocks are ordered by their smallest member index.
pub fn merge_blocks(buildings: &[Building]) -> Vec<Block> {
    merge::merge_blocks(buildings)
}

/// Erode an area by `eps`, conservatively: the result lies inside the exact
/// erosion (every point of it is inside `area` and at least `eps` from its
/// boundary). The distance actually used is `eps + EROSION_SAFETY_MARGIN`.
/// The result may be empty.
pub fn erode(area: &MultiPolygon, eps: f64) -> MultiPolygon {
    erode::erode(area, eps)
}

/// Erode every level of every block. Empty results are dropped.
/// Levels are eroded in parallel; the output order (by block, then level)
/// does not depend on the thread count.
pub fn shrink_blocks(blocks: &[Block], eps: f64) -> Vec<Occluder> {
    shrink_blocks_with(blocks, eps, &memo::ShapeMemo::off())
}

/// [`shrink_blocks`], taking from `memo` every level whose erosion it holds
/// (keyed by eps and the level's area).
pub fn shrink_blocks_with(blocks: &[Block], eps: f64, memo: &memo::ShapeMemo) -> Vec<Occluder> {
    use rayon::prelude::*;
    let levels: Vec<(usize, usize, &Level)> = blocks
        .iter()
        .enumerate()
        .flat_map(|(b, block)| {
            block
                .levels
                .iter()
                .enumerate()
                .map(move |(l, level)| (b, l, level))
        })
        .collect();
    levels
        .par_iter()
        .map(|&(b, l, level)| Occluder {
            block: b,
            level: l,
            height: level.height,
            shape: memo.shape(
                || {
                    memo::MemoKey::new("erode")
                        .number(eps)
                        .shape(&level.area)
                        .finish()
                },
                || erode(&level.area, eps),
            ),
        })
        .filter(|o| !o.shape.is_empty())
        .collect()
}
