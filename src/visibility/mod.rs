//! Cell-to-object visibility: samples on each cell's top edges, software cull
//! maps of the shrunk occluders' shadows, the hierarchical horizon test, and
//! the per-cell potentially visible sets (METHOD.md 3 to 6).
//!
//! An object is in a cell's PVS iff some sample of the cell leaves it not
//! hidden (equivalently: the min over samples of the max over occluder
//! shadows, F, does not reach the object's height at some pixel it touches).
//! Cells that share a vertex or an edge share its samples, so the visible
//! set of every distinct vertex and edge is computed once and a cell's PVS
//! is the union of its three vertices' and three edges' sets.

pub mod bitset;
pub mod cullmap;
pub mod horizon;
pub mod index;
pub mod samples;
pub mod solver;

use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::Result;
use crate::prepare::Scene;
use bitset::ObjectSet;
use index::SceneIndex;
use samples::MeshTopology;
use solver::{DEFAULT_NEAR_FIELD, Solver};

/// Default eye height in metres (a pedestrian's eyes).
pub const DEFAULT_EYE_HEIGHT: f64 = 1.7;

/// Parameters of the bake's visibility stage.
#[derive(Clone, Debug)]
pub struct VisibilityParams {
    /// Eye height h: cells are prisms from 0 to h.
    pub eye_height: f64,
    /// Cull-map pixel size k in metres; k * sqrt(2) / 2 <= eps.
    pub pixel: f64,
    /// Half-size in metres of the near-field cull map around each sample;
    /// beyond it the distance-ordered horizon decides.
    pub near_field: f64,
}

/// The largest pixel size allowed by eps: k * sqrt(2) / 2 <= eps, with a
/// hair of margin for rounding.
pub fn default_pixel(eps: f64) -> f64 {
    eps * std::f64::consts::SQRT_2 * (1.0 - 1e-9)
}

/// Refuse a pixel size that breaks the conservativeness condition.
pub fn check_pixel(eps: f64, pixel: f64) -> Result<()> {
    if !(pixel > 0.0 && pixel.is_finite()) {
        return Err(crate::Error::new(format!(
            "--pixel must be a positive number of metres, got {pixel}"
        )));
    }
    if pixel * std::f64::consts::SQRT_2 / 2.0 > eps {
        return Err(crate::Error::new(format!(
            "--pixel {pixel} is too large for --eps {eps}: a pixel's centre must lie within eps of every point of \
             the pixel (pixel * sqrt(2) / 2 <= eps), or the cull map could hide a visible building; use --pixel {:.6} \
             or less, or a larger --eps",
            default_pixel(eps)
        )));
    }
    Ok(())
}

impl VisibilityParams {
    /// Defaults for a given eps.
    pub fn for_eps(eps: f64) -> Self {
        VisibilityParams {
            eye_height: DEFAULT_EYE_HEIGHT,
            pixel: default_pixel(eps),
            near_field: DEFAULT_NEAR_FIELD,
        }
    }
}

/// The per-cell visible sets and what it took to compute them.
#[derive(Clone, Debug)]
pub struct VisibilityResult {
    /// Per cell, ascending object (building) indices.
    pub visible: Vec<Vec<u32>>,
    /// Distinct sample points (shared vertices and edge points counted once).
    pub samples: usize,
}

/// A unit of shared work: a distinct mesh vertex or the interior of a distinct edge.
enum Unit {
    Vertex(u32),
    Edge(u32),
}

fn unit_points(topo: &MeshTopology, unit: &Unit, spacing: f64) -> Vec<DVec2> {
    match unit {
        Unit::Vertex(v) => vec![topo.vertices[*v as usize]],
        Unit::Edge(e) => topo.edge_interior_samples(*e as usize, spacing),
    }
}

/// Compute every cell's PVS. `progress` is called with 1 after each cell.
pub fn compute_pvs(
    scene: &Scene,
    params: &VisibilityParams,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<VisibilityResult> {
    check_pixel(scene.eps, params.pixel)?;
    if !(params.eye_height > 0.0 && params.eye_height.is_finite()) {
        return Err(crate::Error::new(format!(
            "--eye-height must be a positive number of metres, got {}",
            params.eye_height
        )));
    }
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let spacing = 2.0 * scene.eps;
    let units: Vec<Unit> = (0..topo.vertices.len() as u32)
        .map(Unit::Vertex)
        .chain((0..topo.edges.len() as u32).map(Unit::Edge))
        .collect();
    let results: Vec<OnceLock<ObjectSet>> = (0..units.len()).map(|_| OnceLock::new()).collect();
    let n_objects = scene.city.buildings.len();
    let sample_count = AtomicUsize::new(0);
    let solve_unit = |solver: &mut Solver, u: usize| -> ObjectSet {
        let mut set = ObjectSet::new(n_objects);
        let points = unit_points(&topo, &units[u], spacing);
        sample_count.fetch_add(points.len(), Ordering::Relaxed);
        solver.solve_run(&points, &mut set);
        set
    };
    let n_vertices = topo.vertices.len();
    let visible: Vec<Vec<u32>> = (0..scene.cells.triangles.len())
        .into_par_iter()
        .map_init(
            || Solver::new(&index, params.eye_height, params.near_field),
            |solver, cell| {
                let mut set = ObjectSet::new(n_objects);
                let vs = topo.cell_vertices[cell].iter().map(|&v| v as usize);
                let es = topo.cell_edges[cell]
                    .iter()
                    .map(|&e| n_vertices + e as usize);
                for u in vs.chain(es) {
                    set.union_with(results[u].get_or_init(|| solve_unit(solver, u)));
                }
                progress(1);
                set.to_vec()
            },
        )
        .collect();
    Ok(VisibilityResult {
        visible,
        samples: sample_count.load(Ordering::Relaxed),
    })
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

/// The sample points (x, y, eye height) of one cell's top edges: its
/// corners and the points along its edges, at most 2 * eps apart.
pub fn cell_samples(scene: &Scene, params: &VisibilityParams, cell: usize) -> Vec<DVec3> {
    let t = scene.cells.triangles[cell];
    let mut out = Vec::new();
    for k in 0..3 {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        out.push(a.extend(params.eye_height));
        out.extend(
            samples::interior_samples(a, b, 2.0 * scene.eps)
                .into_iter()
                .map(|p| p.extend(params.eye_height)),
        );
    }
    out
}

/// The final cull map of one cell over the square of half-size `radius`
/// (metres) around the cell.
pub fn cell_cull_map(
    scene: &Scene,
    params: &VisibilityParams,
    cell: usize,
    radius: f64,
) -> CullMapImage {
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    let t = scene.cells.triangles[cell];
    let rect = crate::model::Rect::of_points(t.iter()).grown(radius);
    let (i0, j0) = index.grid.pixel_of(rect.min);
    let (i1, j1) = index.grid.pixel_of(rect.max);
    let (width, height) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    let mut min_map = vec![f32::INFINITY; width * height];
    for s in cell_samples(scene, params, cell) {
        solver.window.reset(i0, j0, width, height);
        solver.rasterise_occluders(s.truncate());
        for (m, u) in min_map.iter_mut().zip(&solver.window.heights) {
            *m = m.min(*u);
        }
    }
    CullMapImage {
        origin: DVec2::new(i0 as f64 * params.pixel, j0 as f64 * params.pixel),
        pixel: params.pixel,
        width,
        height,
        heights: min_map,
    }
}
