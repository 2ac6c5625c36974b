//! The region of interest (a polygon the user gives, or the footprints'
//! bounding box grown by a margin) and the free space inside it: the region
//! minus the blocks' ground footprints.

use geo::BooleanOps;
use geo::bool_ops::FillRule;

use super::CellParams;
use crate::geometry::Block;
use crate::geometry::convert::{multipolygon_from_geo, multipolygon_to_geo};
use crate::model::{MultiPolygon, Polygon, Rect, multipolygon_bounds, ring_signed_area2};
use crate::{Error, Result};

/// The region to triangulate, in the model's conventions.
pub fn region(blocks: &[Block], params: &CellParams) -> Result<Polygon> {
    match &params.region {
        Some(given) => user_region(given),
        None => grown_box(blocks, params.margin),
    }
}

/// The given region, cleaned up (open rings, CCW exterior, CW holes).
fn user_region(given: &Polygon) -> Result<Polygon> {
    let all_finite = std::iter::once(&given.exterior)
        .chain(given.holes.iter())
        .flatten()
        .all(|p| p.is_finite());
    if !all_finite {
        return Err(Error::scene(
            "cells: the region has a non-finite coordinate",
        ));
    }
    let cleaned = multipolygon_from_geo(&multipolygon_to_geo(std::slice::from_ref(given)), 0.0);
    match <[Polygon; 1]>::try_from(cleaned) {
        Ok([polygon]) => Ok(polygon),
        Err(_) => Err(Error::scene(
            "cells: the region's exterior must have at least three distinct vertices and enclose an area",
        )),
    }
}

/// The bounding box of all ground footprints grown by `margin`.
fn grown_box(blocks: &[Block], margin: f64) -> Result<Polygon> {
    if !(margin >= 0.0 && margin.is_finite()) {
        return Err(Error::scene(format!(
            "cells: the margin must be a finite number of metres >= 0, got {margin}"
        )));
    }
    let bounds = blocks
        .iter()
        .filter_map(|b| b.levels.first())
        .map(|level| multipolygon_bounds(&level.area))
        .fold(Rect::EMPTY, |acc, r| acc.union(&r));
    if bounds.is_empty() {
        return Err(Error::scene(
            "cells: there are no occluding buildings to take a region from; give a region",
        ));
    }
    let r = bounds.grown(margin);
    let exterior = vec![
        r.min,
        glam::DVec2::new(r.max.x, r.min.y),
        r.max,
        glam::DVec2::new(r.min.x, r.max.y),
    ];
    if ring_signed_area2(&exterior) <= 0.0 {
        return Err(Error::scene(
            "cells: the footprints' bounding box has no area; give a margin > 0",
        ));
    }
    Ok(Polygon {
        exterior,
        holes: Vec::new(),
    })
}

/// The region minus every block's ground footprint (level 0).
pub fn free_space(region: &Polygon, blocks: &[Block]) -> MultiPolygon {
    let footprints: Vec<Polygon> = blocks
        .iter()
        .filter_map(|b| b.levels.first())
        .flat_map(|level| level.area.iter().cloned())
        .collect();
    let region = multipolygon_to_geo(std::slice::from_ref(region));
    if footprints.is_empty() {
        return multipolygon_from_geo(&region.union(&geo::MultiPolygon::new(vec![])), 0.0);
    }
    let solid = multipolygon_to_geo(&footprints);
    multipolygon_from_geo(
        &region.difference_with_fill_rule(&solid, FillRule::NonZero),
        0.0,
    )
}

/// `a` minus `b`, pieces under 1e-6 m2 left out.
pub fn difference(a: &MultiPolygon, b: &MultiPolygon) -> MultiPolygon {
    let a = multipolygon_to_geo(a);
    let b = multipolygon_to_geo(b);
    multipolygon_from_geo(&a.difference_with_fill_rule(&b, FillRule::NonZero), 1e-6)
}
