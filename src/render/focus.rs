//! The chosen cell of a picture: its visible set (read from a `.pvs` file or
//! computed here with the bake's own code) and its sample points.

use glam::DVec2;

use crate::prepare::Scene;
use crate::visibility::VisibilityEngine;
use crate::{Error, Result};

/// A chosen cell and what it sees.
#[derive(Clone, Debug, PartialEq)]
pub struct Focus {
    /// Index of the cell in `scene.cells.triangles`.
    pub cell: usize,
    /// Ascending indices of the buildings in its PVS.
    pub visible: Vec<u32>,
    /// Its sample points (on its top edges), seen from above.
    pub samples: Vec<DVec2>,
}

fn check_cell(scene: &Scene, cell: usize) -> Result<()> {
    let cells = scene.cells.triangles.len();
    if cell >= cells {
        return Err(Error::usage(format!(
            "cell {cell} does not exist (the scene has {cells} cells, numbered from 0)"
        )));
    }
    Ok(())
}

impl Focus {
    /// A focus on `cell` with a visible set found elsewhere (e.g. a `.pvs`
    /// file). The set must name existing buildings in ascending order.
    pub fn new(scene: &Scene, cell: usize, visible: Vec<u32>) -> Result<Focus> {
        check_cell(scene, cell)?;
        let buildings = scene.city.buildings.len();
        if let Some(&bad) = visible.iter().find(|&&o| o as usize >= buildings) {
            return Err(Error::usage(format!(
                "cell {cell}: visible object {bad} does not exist (the city has {buildings} buildings)"
            )));
        }
        if visible.windows(2).any(|w| w[0] >= w[1]) {
            return Err(Error::usage(format!(
                "cell {cell}: the visible set is not in ascending order"
            )));
        }
        let samples = crate::visibility::samples::cell_sample_points(
            &scene.cells.triangles[cell],
            scene.settings.sample_spacing(),
        );
        Ok(Focus {
            cell,
            visible,
            samples,
        })
    }

    /// A focus on `cell` with its PVS computed by the bake's engine.
    pub fn compute(scene: &Scene, cell: usize) -> Result<Focus> {
        check_cell(scene, cell)?;
        let visible = VisibilityEngine::new(scene)?.solve_cell(cell);
        Focus::new(scene, cell, visible)
    }

    /// True when building `b` is in the PVS.
    pub fn sees(&self, b: usize) -> bool {
        self.visible.binary_search(&(b as u32)).is_ok()
    }
}
