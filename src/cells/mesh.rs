//! The constrained Delaunay triangulation of free space (spade): outlines as
//! constraint edges pre-split to the edge bound, Delaunay refinement with an
//! area bound, then midpoint insertion until no cell edge is too long.

use glam::DVec2;
use spade::handles::FixedFaceHandle;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, InsertionError, Point2, RefinementParameters,
    Triangulation,
};

use crate::model::{MultiPolygon, multipolygon_area};
use crate::{Error, Result};

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// The triangulation will not grow beyond this many vertices: a guard
/// against a region far too large for its edge bound.
pub const MAX_VERTICES: usize = 20_000_000;

/// Rounds of midpoint insertion before giving up.
const MAX_SPLIT_ROUNDS: usize = 100;

/// Counter-clockwise triangles covering `free` exactly, every edge at most
/// `max_edge` long, in spade's (deterministic) face order.
pub fn triangulate_free_space(free: &MultiPolygon, max_edge: f64) -> Result<Vec<[DVec2; 3]>> {
    let area = multipolygon_area(free);
    // An equilateral triangle with edge max_edge has area 0.433 max_edge^2;
    // refinement leaves triangles of about a quarter of that.
    let expected_vertices = area / (0.1 * max_edge * max_edge);
    if expected_vertices > MAX_VERTICES as f64 {
        return Err(Error::new(format!(
            "cells: a free area of {area:.0} m2 with cell edges of at most {max_edge} m needs \
             about {expected_vertices:.0} vertices, more than the limit of {MAX_VERTICES}; \
             give a larger --max-cell-edge or a smaller region"
        )));
    }
    let mut cdt = constrained(free, max_edge).map_err(insertion_error)?;
    refine(&mut cdt, max_edge, expected_vertices as usize);
    split_long_edges(&mut cdt, max_edge)?;
    let free_faces = free_faces(&cdt);
    Ok(cdt
        .inner_faces()
        .filter(|f| free_faces[f.fix().index()])
        .map(|f| f.positions().map(|p| DVec2::new(p.x, p.y)))
        .collect())
}

fn insertion_error(e: InsertionError) -> Error {
    Error::new(format!("cells: the triangulation rejected a vertex: {e:?}"))
}

/// The CDT with every ring of `free` as constraint edges, each edge
/// pre-split into pieces no longer than `max_edge`.
fn constrained(free: &MultiPolygon, max_edge: f64) -> std::result::Result<Cdt, InsertionError> {
    let mut vertices = Vec::new();
    let mut edges = Vec::new();
    for ring in free
        .iter()
        .flat_map(|p| std::iter::once(&p.exterior).chain(p.holes.iter()))
    {
        let start = vertices.len();
        for (i, &a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            let pieces = ((b - a).length() / max_edge).ceil().max(1.0) as usize;
            for k in 0..pieces {
                let p = a + (b - a) * (k as f64 / pieces as f64);
                vertices.push(Point2::new(p.x, p.y));
            }
        }
        let end = vertices.len();
        edges.extend((start..end).map(|i| [i, if i + 1 == end { start } else { i + 1 }]));
    }
    let mut conflicts = Vec::new();
    let mut cdt = Cdt::try_bulk_load_cdt(vertices, edges, |e| conflicts.push(e))?;
    // Crossing outlines cannot come out of the boolean operation, but if
    // rounding makes two touch, split them where they cross rather than
    // lose a constraint.
    for [a, b] in conflicts {
        use spade::handles::FixedVertexHandle;
        cdt.add_constraint_and_split(
            FixedVertexHandle::from_index(a),
            FixedVertexHandle::from_index(b),
            |p| p,
        );
    }
    Ok(cdt)
}

/// Delaunay refinement of the free faces with an area bound that makes most
/// edges shorter than `max_edge`.
fn refine(cdt: &mut Cdt, max_edge: f64, expected_vertices: usize) {
    let m2 = max_edge * max_edge;
    let params = RefinementParameters::<f64>::new()
        .exclude_outer_faces(true)
        .with_angle_limit(AngleLimit::from_deg(20.0))
        .with_max_allowed_area(0.25 * m2)
        .with_min_required_area(1e-3 * m2)
        .with_max_additional_vertices(4 * expected_vertices + 10 * cdt.num_vertices() + 1000);
    cdt.refine(params);
}

/// Insert the midpoints of free edges longer than `max_edge` until there
/// are none. Constraint edges are already short enough, so every long edge
/// lies inside free space and its midpoint is a free point.
fn split_long_edges(cdt: &mut Cdt, max_edge: f64) -> Result<()> {
    let limit2 = max_edge * max_edge;
    for _ in 0..MAX_SPLIT_ROUNDS {
        let free = free_faces(cdt);
        let mut seen = vec![false; cdt.num_undirected_edges()];
        let mut midpoints = Vec::new();
        for face in cdt.inner_faces().filter(|f| free[f.fix().index()]) {
            for edge in face.adjacent_edges() {
                let undirected = edge.as_undirected();
                if seen[undirected.index()] || edge.length_2() <= limit2 {
                    continue;
                }
                seen[undirected.index()] = true;
                let [a, b] = edge.positions();
                midpoints.push(Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y)));
            }
        }
        if midpoints.is_empty() {
            return Ok(());
        }
        for p in midpoints {
            cdt.insert(p).map_err(insertion_error)?;
        }
        if cdt.num_vertices() > MAX_VERTICES {
            break;
        }
    }
    Err(Error::new(format!(
        "cells: could not bring every cell edge under {max_edge} m"
    )))
}

/// For every face index, whether it is free space: reached from outside by
/// crossing an odd number of constraint edges (the outlines of free space).
fn free_faces(cdt: &Cdt) -> Vec<bool> {
    const UNSEEN: u8 = 2;
    let mut parity = vec![UNSEEN; cdt.num_all_faces()];
    let mut stack: Vec<(FixedFaceHandle<spade::handles::InnerTag>, u8)> = Vec::new();
    for hull_edge in cdt.convex_hull() {
        if let Some(face) = hull_edge.rev().face().as_inner() {
            stack.push((face.fix(), u8::from(hull_edge.is_constraint_edge())));
        }
    }
    while let Some((face, p)) = stack.pop() {
        if parity[face.index()] != UNSEEN {
            continue;
        }
        parity[face.index()] = p;
        for edge in cdt.face(face).adjacent_edges() {
            if let Some(next) = edge.rev().face().as_inner()
                && parity[next.fix().index()] == UNSEEN
            {
                stack.push((next.fix(), p ^ u8::from(edge.is_constraint_edge())));
            }
        }
    }
    parity.into_iter().map(|p| p == 1).collect()
}
