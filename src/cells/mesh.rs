//! The constrained Delaunay triangulation of free space (spade): outlines as
//! constraint edges pre-split to the edge bound, a triangular lattice of
//! points over the open parts, Delaunay refinement with an area bound, then
//! conforming longest-edge bisection until no cell edge is too long.

use glam::DVec2;
use spade::handles::FixedFaceHandle;
use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, InsertionError, Point2, PositionInTriangulation,
    RefinementParameters, Triangulation,
};

use super::bisect::{Mesh, bisect_long_edges};
use super::lattice::lattice_points;
use crate::model::{MultiPolygon, Rect, cut_points, multipolygon_area, piece_count, polygon_edges};
use crate::{Error, Result};

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// The triangulation will not grow beyond this many vertices: a guard
/// against a region far too large for its edge bound.
pub const MAX_VERTICES: usize = 5_000_000;

/// Spacing of the lattice of points in open areas, relative to the edge
/// bound: its equilateral triangles are a little shorter than the bound.
const LATTICE_SPACING: f64 = 0.95;

/// Lattice points closer than this (relative to the spacing) to an outline
/// are left out; the refinement fills the band along the outlines. 0.7 gave
/// the least total edge length on generated cities.
const LATTICE_CLEARANCE: f64 = 0.7;

/// Counter-clockwise triangles covering `free` exactly, every edge at most
/// `max_edge` long, ordered along a Morton curve of their centroids (ties
/// in spade's deterministic face order), so that neighbouring cells are
/// mostly close in the list.
pub fn triangulate_free_space(free: &MultiPolygon, max_edge: f64) -> Result<Vec<[DVec2; 3]>> {
    let area = multipolygon_area(free);
    // A generous estimate: on generated cities and Kotka each vertex carries
    // about 0.2 max_edge^2 of free area (two cells of 0.1 max_edge^2), and
    // the outlines are split into pieces of at most max_edge.
    let perimeter: f64 = free
        .iter()
        .flat_map(polygon_edges)
        .map(|(a, b)| a.distance(b))
        .sum();
    let expected_vertices = area / (0.1 * max_edge * max_edge) + perimeter / max_edge;
    if expected_vertices > MAX_VERTICES as f64 {
        return Err(Error::scene(format!(
            "cells: a free area of {area:.0} m2 and {perimeter:.0} m of outlines with cell edges of at most {max_edge} m need \
             about {expected_vertices:.0} vertices, more than the limit of {MAX_VERTICES}; \
             give a larger --max-cell-edge or a smaller region"
        )));
    }
    let mut cdt = constrained(free, max_edge).map_err(insertion_error)?;
    insert_lattice(&mut cdt, free, LATTICE_SPACING * max_edge)?;
    refine(&mut cdt, max_edge, expected_vertices as usize);
    let mut mesh = free_mesh(&cdt);
    bisect_long_edges(&mut mesh, max_edge);
    let mut triangles: Vec<[DVec2; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.vertices[i as usize]))
        .collect();
    sort_along_morton_curve(&mut triangles);
    Ok(triangles)
}

/// Stable sort of triangles by the Morton code of their centroids on a
/// 2^20 x 2^20 grid over their bounding box.
fn sort_along_morton_curve(triangles: &mut [[DVec2; 3]]) {
    const CELLS: f64 = (1u32 << 20) as f64;
    let bounds = Rect::of_points(triangles.iter().flatten());
    let size = (bounds.max - bounds.min).max(DVec2::splat(f64::MIN_POSITIVE));
    let code = |t: &[DVec2; 3]| {
        let c = ((t[0] + t[1] + t[2]) / 3.0 - bounds.min) / size * CELLS;
        let x = c.x.clamp(0.0, CELLS - 1.0) as u64;
        let y = c.y.clamp(0.0, CELLS - 1.0) as u64;
        spread_bits(x) | (spread_bits(y) << 1)
    };
    triangles.sort_by_cached_key(code);
}

/// The low 32 bits of `v` moved to the even bit positions.
fn spread_bits(v: u64) -> u64 {
    let mut v = v & 0xffff_ffff;
    v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
    v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
    v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    v = (v | (v << 2)) & 0x3333_3333_3333_3333;
    (v | (v << 1)) & 0x5555_5555_5555_5555
}

fn insertion_error(e: InsertionError) -> Error {
    Error::scene(format!("cells: the triangulation rejected a vertex: {e:?}"))
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
            let pieces = piece_count(a, b, max_edge);
            // Each edge gives its start and inner points; the next edge
            // gives this one's end.
            for p in cut_points(a, b, pieces).take(pieces) {
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

/// Insert the lattice points of [`lattice_points`] that fall in free faces.
fn insert_lattice(cdt: &mut Cdt, free: &MultiPolygon, spacing: f64) -> Result<()> {
    let free_now = free_faces(cdt);
    let inside = lattice_points(
        free,
        spacing,
        LATTICE_CLEARANCE * spacing,
        MAX_VERTICES,
        |p| match cdt.locate(Point2::new(p.x, p.y)) {
            PositionInTriangulation::OnFace(f) => free_now[f.index()],
            _ => false,
        },
    );
    for p in inside {
        cdt.insert(Point2::new(p.x, p.y)).map_err(insertion_error)?;
    }
    Ok(())
}

/// The refinement's minimum angle, degrees. The cells only need to be
/// thick enough (few thinner than 5 cm), not round: spade splits every
/// outline piece that a vertex encroaches on (comes into its diametral
/// circle) whatever the angle limit, and that alone keeps the cells along
/// walls and in passages about as thick as the free space is wide. A 20
/// degree limit also split the outlines around every short edge and sharp
/// corner (passage mouths, light wells, closed slits) and graded the cells
/// down towards them: on the old-town style 1.5 times the outline vertices
/// and 1.6 times the cells of this limit, 3 times within 2 m of a wall
/// (the generated default style 2% more cells, Kotka 26% more), with about
/// the same counts of cells thinner than 5, 10 and 20 cm. At 0-2 degrees
/// one of three old towns got a sliver 1.5 cm thin.
const MIN_ANGLE_DEG: f64 = 3.0;

/// Delaunay refinement of the free faces with an area bound that makes most
/// edges shorter than `max_edge` (the bisection does the rest): a minimum
/// angle of [`MIN_ANGLE_DEG`] and at most 0.45 max_edge^2, chosen by cell
/// count and total edge length on generated cities (an equilateral
/// triangle of edge max_edge has 0.433 max_edge^2, so the lattice's
/// triangles are left alone; 0.35 or 0.6 give more cells).
fn refine(cdt: &mut Cdt, max_edge: f64, expected_vertices: usize) {
    let m2 = max_edge * max_edge;
    let params = RefinementParameters::<f64>::new()
        .exclude_outer_faces(true)
        .with_angle_limit(AngleLimit::from_deg(MIN_ANGLE_DEG))
        .with_max_allowed_area(0.45 * m2)
        .with_min_required_area(1e-3 * m2)
        .with_max_additional_vertices(
            (4 * expected_vertices + 10 * cdt.num_vertices() + 1000).min(MAX_VERTICES),
        );
    cdt.refine(params);
}

/// The free faces of the triangulation as an indexed mesh (spade's vertex
/// indices, so shared corners are shared indices).
fn free_mesh(cdt: &Cdt) -> Mesh {
    let free = free_faces(cdt);
    Mesh {
        vertices: cdt
            .vertices()
            .map(|v| DVec2::new(v.position().x, v.position().y))
            .collect(),
        triangles: cdt
            .inner_faces()
            .filter(|f| free[f.fix().index()])
            .map(|f| f.vertices().map(|v| v.fix().index() as u32))
            .collect(),
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_bits_interleave() {
        assert_eq!(spread_bits(0b1011), 0b1000101);
        assert_eq!(spread_bits(u64::MAX), 0x5555_5555_5555_5555);
    }
}
