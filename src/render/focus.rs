//! The chosen cell of a picture: its visible set (read from a `.pvs` file or
//! computed here with the bake's own code) and its sample points.

use glam::DVec2;

use crate::cells::Cells;
use crate::prepare::Scene;
use crate::visibility::{VisibilityParams, cell_samples, compute_pvs};
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
        return Err(Error::new(format!(
            "cell {cell} does not exist (the scene has {cells} cells, numbered from 0)"
        )));
    }
    Ok(())
}

impl Focus {
    /// A focus on `cell` with a visible set found elsewhere (e.g. a `.pvs`
    /// file). The set must name existing buildings in ascending order.
    pub fn new(
        scene: &Scene,
        params: &VisibilityParams,
        cell: usize,
        visible: Vec<u32>,
    ) -> Result<Focus> {
        check_cell(scene, cell)?;
        let buildings = scene.city.buildings.len();
        if let Some(&bad) = visible.iter().find(|&&o| o as usize >= buildings) {
            return Err(Error::new(format!(
                "cell {cell}: visible object {bad} does not exist (the city has {buildings} buildings)"
            )));
        }
        if visible.windows(2).any(|w| w[0] >= w[1]) {
            return Err(Error::new(format!(
                "cell {cell}: the visible set is not in ascending order"
            )));
        }
        let samples = cell_samples(scene, params, cell)
            .into_iter()
            .map(|s| s.truncate())
            .collect();
        Ok(Focus {
            cell,
            visible,
            samples,
        })
    }

    /// A focus on `cell` with its PVS computed by the bake's code on a scene
    /// holding only that cell (the same samples, so the same set).
    pub fn compute(scene: &Scene, params: &VisibilityParams, cell: usize) -> Result<Focus> {
        check_cell(scene, cell)?;
        let alone = Scene {
            city: scene.city.clone(),
            blocks: Vec::new(),
            occluders: scene.occluders.clone(),
            cells: Cells {
                triangles: vec![scene.cells.triangles[cell]],
                region: scene.cells.region.clone(),
                open_area: scene.cells.open_area,
                dropped: Vec::new(),
                min_gap: scene.cells.min_gap,
            },
            eps: scene.eps,
            timings: Vec::new(),
        };
        let mut result = compute_pvs(&alone, params, &|_| {})?;
        let visible = result.visible.pop().unwrap_or_default();
        Focus::new(scene, params, cell, visible)
    }

    /// True when building `b` is in the PVS.
    pub fn sees(&self, b: usize) -> bool {
        self.visible.binary_search(&(b as u32)).is_ok()
    }
}
