//! One picture request served end to end: the chosen cell's visible set
//! (read from a `.pvs` file or solved by the engine), its cull map and every
//! cell's PVS size as asked, then the drawing.

use crate::Result;
use crate::prepare::Scene;
use crate::pvs::PvsReader;
use crate::visibility::VisibilityEngine;

use super::{Focus, Picture, Rendered, render, view_around};

/// Half-size in metres of the cull map drawn around the chosen cell when
/// no radius is given.
pub const DEFAULT_CULL_MAP_RADIUS: f64 = 160.0;

/// What to draw.
#[derive(Clone, Debug, Default)]
pub struct Request {
    /// The chosen cell, if any.
    pub cell: Option<usize>,
    /// Draw the chosen cell's cull map.
    pub cull_map: bool,
    /// Colour every cell by its PVS size.
    pub pvs_size: bool,
    /// Show only this half-size around the chosen cell (and draw its cull
    /// map that far).
    pub radius: Option<f64>,
    /// Picture width in pixels.
    pub width: u32,
}

/// A drawn picture and the chosen cell it shows, if any.
pub struct Drawing {
    pub rendered: Rendered,
    pub focus: Option<Focus>,
}

/// Gather what the request needs (from `reader` when given, else from the
/// engine) and draw it. The reader must hold a bake of this scene.
pub fn draw(scene: &Scene, reader: Option<&PvsReader>, request: &Request) -> Result<Drawing> {
    let cell = request.cell;
    let needs_engine =
        request.cull_map || (reader.is_none() && (cell.is_some() || request.pvs_size));
    let engine = if needs_engine {
        Some(VisibilityEngine::new(scene)?)
    } else {
        None
    };
    let focus = match (cell, reader, &engine) {
        (Some(c), Some(r), _) => Some(Focus::new(scene, c, r.visible(c)?)?),
        (Some(c), None, Some(e)) => Some(Focus::new(scene, c, e.solve_cell(c))?),
        _ => None,
    };
    let cull_map = match (cell, &engine) {
        (Some(c), Some(e)) if request.cull_map => {
            Some(e.cull_map(c, request.radius.unwrap_or(DEFAULT_CULL_MAP_RADIUS))?)
        }
        _ => None,
    };
    let pvs_sizes: Option<Vec<usize>> = match (reader, &engine) {
        _ if !request.pvs_size => None,
        (Some(r), _) => Some(
            (0..r.cell_count())
                .map(|c| r.visible(c).map(|v| v.len()))
                .collect::<Result<_>>()?,
        ),
        (None, Some(engine)) => {
            let mut sizes = Vec::with_capacity(engine.cell_count());
            engine.solve_cells(0..engine.cell_count(), &|_| {}, |_, set| {
                sizes.push(set.len());
                Ok(())
            })?;
            Some(sizes)
        }
        (None, None) => None,
    };
    let view = match (cell, request.radius) {
        (Some(c), Some(r)) => Some(view_around(scene, c, r)),
        _ => None,
    };
    let rendered = render(&Picture {
        scene,
        focus: focus.as_ref(),
        cull_map: cull_map.as_ref(),
        pvs_sizes: pvs_sizes.as_deref(),
        view,
        width: request.width,
    })?;
    Ok(Drawing { rendered, focus })
}
