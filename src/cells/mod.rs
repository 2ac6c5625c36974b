//! View cells: the constrained Delaunay triangulation (spade) of free space,
//! refined so that no cell edge exceeds a bound (docs/METHOD.md §2).
//!
//! The types and [`triangulate`] below are the interface; `region` makes
//! the region and free space, `mesh` triangulates and refines it (with
//! `lattice` points over open ground and `bisect` for the edge bound).

mod bisect;
mod lattice;
mod mesh;
pub mod narrow;
mod region;
mod straighten;
pub mod tiles;

pub use mesh::MAX_VERTICES;

use glam::DVec2;

use crate::Result;
use crate::geometry::Block;
use crate::geometry::memo::ShapeMemo;
use crate::model::{MultiPolygon, Polygon, multipolygon_area};

pub use crate::settings::{DEFAULT_MARGIN, DEFAULT_MAX_CELL_EDGE, DEFAULT_MIN_GAP};

/// The triangles with every corner moved to the nearest point of the
/// 1/256 m grid the file stores (`crate::pvs::mesh::snap`), in the same
/// order. Shared corners stay shared; a corner moves at most
/// `SNAP_DISTANCE` (2.8 mm). A triangle may become thinner, flat or turned
/// over; its set is still computed for the triangle as it now is, which is
/// what the file holds and what a reader's point lookup tests
/// (docs/METHOD.md, section 4, "Cell corners on a grid").
fn on_grid(triangles: Vec<[DVec2; 3]>) -> Result<Vec<[DVec2; 3]>> {
    triangles
        .into_iter()
        .map(|t| {
            let mut out = [DVec2::ZERO; 3];
            for (o, p) in out.iter_mut().zip(t) {
                *o = crate::pvs::mesh::snap(p).ok_or_else(|| {
                    crate::Error::scene(format!(
                        "cells: corner ({}, {}) is too far from the origin for the 1/256 m grid",
                        p.x, p.y
                    ))
                })?;
            }
            Ok(out)
        })
        .collect()
}

/// How to cut free space into cells.
#[derive(Clone, Debug)]
pub struct CellParams {
    /// Margin around the footprints' bounding box (ignored with `region`).
    pub margin: f64,
    /// No cell edge may be longer than this.
    pub max_edge: f64,
    /// A user-given region of interest (local metres) instead of the box.
    pub region: Option<Polygon>,
    /// Free space narrower than this (metres) is not free space: no cells
    /// there. 0 keeps every gap. Occluders never change.
    pub min_gap: f64,
}

impl Default for CellParams {
    fn default() -> Self {
        CellParams {
            margin: DEFAULT_MARGIN,
            max_edge: DEFAULT_MAX_CELL_EDGE,
            region: None,
            min_gap: DEFAULT_MIN_GAP,
        }
    }
}

/// The view cells: triangles covering free space, their corners on the
/// 1/256 m grid (so up to 2.8 mm off the free space's outline).
#[derive(Clone, Debug)]
pub struct Cells {
    /// Triangles in local metres, corners on the 1/256 m grid, in a
    /// deterministic order; counter-clockwise before the corners were put
    /// on the grid (a sliver may have turned over).
    pub triangles: Vec<[DVec2; 3]>,
    /// The region of interest that was triangulated.
    pub region: Polygon,
    /// Area in square metres of the free space (region minus footprints)
    /// before narrow parts were dropped.
    pub open_area: f64,
    /// The free space that was dropped as too narrow (or within the
    /// clearance of a footprint), for display.
    pub dropped: MultiPolygon,
    /// The minimum gap the free space was opened with (metres).
    pub min_gap: f64,
}

/// Triangulate the free space of the region minus the blocks' ground
/// footprints (level 0 of each block). Courtyards are free space. Fails
/// (never panics) when there is no region to take, the parameters make no
/// sense, or nothing of the region is free.
pub fn triangulate(blocks: &[Block], params: &CellParams) -> Result<Cells> {
    triangulate_with(blocks, params, &ShapeMemo::off())
}

/// [`triangulate`], taking from `memo` every tile of the opening whose
/// result it holds.
pub fn triangulate_with(blocks: &[Block], params: &CellParams, memo: &ShapeMemo) -> Result<Cells> {
    let mut cells = exact_with(blocks, params, memo)?;
    cells.triangles = on_grid(std::mem::take(&mut cells.triangles))?;
    Ok(cells)
}

/// [`triangulate`] before the corners are put on the grid: triangles that
/// tile the free space exactly (counter-clockwise, every edge within the
/// bound). What the bake uses is this, each corner moved to the grid.
pub fn triangulate_exact(blocks: &[Block], params: &CellParams) -> Result<Cells> {
    exact_with(blocks, params, &ShapeMemo::off())
}

fn exact_with(blocks: &[Block], params: &CellParams, memo: &ShapeMemo) -> Result<Cells> {
    if !(params.max_edge > 0.0 && params.max_edge.is_finite()) {
        return Err(crate::Error::scene(format!(
            "cells: the maximum cell edge must be a positive number of metres, got {}",
            params.max_edge
        )));
    }
    if !(params.min_gap >= 0.0 && params.min_gap.is_finite()) {
        return Err(crate::Error::scene(format!(
            "cells: the minimum gap must be zero or a positive number of metres, got {}",
            params.min_gap
        )));
    }
    let region = region::region(blocks, params)?;
    let all_free = region::free_space(&region, blocks);
    let open_area = multipolygon_area(&all_free);
    let free = narrow::open_free_space(&all_free, params.min_gap, memo).free;
    let dropped = if params.min_gap > 0.0 {
        region::difference(&all_free, &free)
    } else {
        Vec::new()
    };
    if free.is_empty() {
        return Err(crate::Error::scene(
            "cells: no free space is left in the region once the footprints are removed",
        ));
    }
    let triangles = mesh::triangulate_free_space(&free, params.max_edge)?;
    Ok(Cells {
        triangles,
        region,
        open_area,
        dropped,
        min_gap: params.min_gap,
    })
}
