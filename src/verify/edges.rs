//! The judge's own index of the original footprint edges: a uniform grid of
//! edge lists, and a ray walk that reports every edge a ray crosses in order
//! of distance.

use glam::DVec2;

use crate::grid::{CellLists, Key, UniformGrid};
use crate::model::{Building, Rect, multipolygon_bounds, polygon_edges};

/// One footprint edge of one building, `a` to `b`.
#[derive(Clone, Copy, Debug)]
pub struct Edge {
    pub a: DVec2,
    pub b: DVec2,
    pub building: u32,
}

/// Where a ray crosses an edge.
#[derive(Clone, Copy, Debug)]
pub struct Crossing {
    /// Distance along the (unit) ray.
    pub t: f64,
    pub edge: u32,
    pub building: u32,
}

/// Every footprint edge, bucketed by a uniform grid over their bounding box.
#[derive(Debug)]
pub struct EdgeGrid {
    pub edges: Vec<Edge>,
    /// The edges' (slightly grown) bounding box; the grid starts at its
    /// lower left corner and covers it.
    bounds: Rect,
    grid: UniformGrid,
    /// Per grid cell, the edges whose slightly grown bounding box touches it.
    lists: CellLists,
}

/// Grid cells per edge (on average) the grid aims for.
const EDGES_PER_CELL: f64 = 2.0;
/// The grid never has more cells than this.
const MAX_GRID_CELLS: f64 = 4.0e6;

/// Per-thread scratch for ray walks: which edges this ray already tested.
#[derive(Debug, Default)]
pub struct RayScratch {
    stamp: Vec<u32>,
    ray: u32,
    pending: Vec<Crossing>,
}

impl EdgeGrid {
    pub fn new(buildings: &[Building]) -> EdgeGrid {
        let mut edges = Vec::new();
        let mut bounds = Rect::EMPTY;
        for (i, b) in buildings.iter().enumerate() {
            bounds = bounds.union(&multipolygon_bounds(&b.footprint));
            for poly in &b.footprint {
                for (a, bb) in polygon_edges(poly) {
                    if a != bb {
                        edges.push(Edge {
                            a,
                            b: bb,
                            building: i as u32,
                        });
                    }
                }
            }
        }
        if edges.is_empty() {
            bounds = Rect {
                min: DVec2::ZERO,
                max: DVec2::ONE,
            };
        }
        let span = (bounds.width().max(bounds.height())).max(1e-3);
        let bounds = bounds.grown(1e-6 * span + 1e-9);
        let area = bounds.width() * bounds.height();
        let wanted = (edges.len() as f64 / EDGES_PER_CELL).clamp(1.0, MAX_GRID_CELLS);
        let mut cell = (area / wanted).sqrt();
        // Never more than MAX_GRID_CELLS, even for long thin cities.
        while (bounds.width() / cell).ceil() * (bounds.height() / cell).ceil() > MAX_GRID_CELLS {
            cell *= 1.5;
        }
        // Each edge is listed in every grid cell its slightly grown bounding
        // box touches; long diagonal edges touch many. Count before
        // allocating, and coarsen while the lists would be too long.
        let max_items = 16 * edges.len() as u64 + 4_000_000;
        let grid = loop {
            let (nx, ny) = UniformGrid::cells_to_cover(&bounds, cell);
            let grid = UniformGrid::square(bounds.min, cell, nx, ny);
            let items = CellLists::total(&grid, edges.len(), |e| edge_cells(&grid, &edges[e]));
            if items <= max_items || grid.len() == 1 {
                break grid;
            }
            cell *= 2.0;
        };
        let lists = CellLists::build(&grid, edges.len(), |e| edge_cells(&grid, &edges[e]));
        EdgeGrid {
            edges,
            bounds,
            grid,
            lists,
        }
    }

    /// The edge lists of all grid cells.
    pub fn cell_lists(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.lists.iter()
    }

    /// Every point where edges of two different buildings cross (footprints
    /// that overlap), sorted and without repeats.
    pub fn crossings_between_buildings(&self) -> Vec<DVec2> {
        let mut points = Vec::new();
        for list in self.cell_lists() {
            for (k, &i) in list.iter().enumerate() {
                let e = &self.edges[i as usize];
                for &j in &list[k + 1..] {
                    let f = &self.edges[j as usize];
                    if e.building == f.building {
                        continue;
                    }
                    if let Some(p) = proper_crossing(e.a, e.b, f.a, f.b) {
                        points.push(p);
                    }
                }
            }
        }
        points.sort_by(|p, q| p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y)));
        points.dedup();
        points
    }

    /// Walk the ray `origin + t * dir` (`dir` a unit vector, t > 0) through
    /// the grid, calling `visit` with batches of crossings in increasing `t`.
    /// An edge crosses the ray when its end points lie strictly on opposite
    /// sides, one side counting end points on the line (so a ring is always
    /// crossed an even number of times by a whole line). `visit` returns
    /// false to stop the walk.
    pub fn walk(
        &self,
        origin: DVec2,
        dir: DVec2,
        scratch: &mut RayScratch,
        mut visit: impl FnMut(&[Crossing]) -> bool,
    ) {
        if scratch.stamp.len() != self.edges.len() {
            scratch.stamp = vec![0; self.edges.len()];
            scratch.ray = 0;
        }
        scratch.ray = scratch.ray.wrapping_add(1);
        if scratch.ray == 0 {
            scratch.stamp.fill(0);
            scratch.ray = 1;
        }
        scratch.pending.clear();
        let Some((t_in, t_out)) = self.clip(origin, dir) else {
            return;
        };
        let start = origin + dir * t_in;
        let g = &self.grid;
        let (mut x, mut y) = g.key(start);
        let step_x: isize = if dir.x > 0.0 { 1 } else { -1 };
        let step_y: isize = if dir.y > 0.0 { 1 } else { -1 };
        let mut t_max_x = if dir.x != 0.0 {
            (g.column_exit(x, step_x > 0) - origin.x) / dir.x
        } else {
            f64::INFINITY
        };
        let mut t_max_y = if dir.y != 0.0 {
            (g.row_exit(y, step_y > 0) - origin.y) / dir.y
        } else {
            f64::INFINITY
        };
        let cell = g.cell_size();
        let t_dx = cell / dir.x.abs();
        let t_dy = cell / dir.y.abs();
        // Crossings closer than this to the current cell's exit wait for the
        // next cell, so that rounding at cell borders cannot reorder them.
        let slack = 1e-7 * (1.0 + cell);
        loop {
            for &e in self.lists.get(g.index((x, y))) {
                if scratch.stamp[e as usize] == scratch.ray {
                    continue;
                }
                scratch.stamp[e as usize] = scratch.ray;
                let edge = &self.edges[e as usize];
                let sa = dir.perp_dot(edge.a - origin);
                let sb = dir.perp_dot(edge.b - origin);
                if (sa > 0.0) == (sb > 0.0) {
                    continue;
                }
                let lambda = sa / (sa - sb);
                let p = edge.a + (edge.b - edge.a) * lambda;
                let t = (p - origin).dot(dir);
                if t > 0.0 {
                    scratch.pending.push(Crossing {
                        t,
                        edge: e,
                        building: edge.building,
                    });
                }
            }
            let t_exit = t_max_x.min(t_max_y);
            let last = t_exit >= t_out;
            let release_below = if last { f64::INFINITY } else { t_exit - slack };
            if !scratch.pending.is_empty() {
                scratch
                    .pending
                    .sort_by(|a, b| a.t.total_cmp(&b.t).then(a.edge.cmp(&b.edge)));
                let n = scratch.pending.partition_point(|c| c.t < release_below);
                if n > 0 {
                    let keep_going = visit(&scratch.pending[..n]);
                    scratch.pending.drain(..n);
                    if !keep_going {
                        return;
                    }
                }
            }
            if last {
                return;
            }
            if t_max_x < t_max_y {
                let nx = x as isize + step_x;
                if nx < 0 || nx >= g.nx() as isize {
                    break;
                }
                x = nx as usize;
                t_max_x += t_dx;
            } else {
                let ny = y as isize + step_y;
                if ny < 0 || ny >= g.ny() as isize {
                    break;
                }
                y = ny as usize;
                t_max_y += t_dy;
            }
        }
        if !scratch.pending.is_empty() {
            scratch
                .pending
                .sort_by(|a, b| a.t.total_cmp(&b.t).then(a.edge.cmp(&b.edge)));
            visit(&scratch.pending);
        }
    }

    /// The part `[t_in, t_out]` (t_in >= 0) of the ray inside the grid bounds.
    fn clip(&self, origin: DVec2, dir: DVec2) -> Option<(f64, f64)> {
        let mut t0: f64 = 0.0;
        let mut t1 = f64::INFINITY;
        for (o, d, lo, hi) in [
            (origin.x, dir.x, self.bounds.min.x, self.bounds.max.x),
            (origin.y, dir.y, self.bounds.min.y, self.bounds.max.y),
        ] {
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (a, b) = ((lo - o) / d, (hi - o) / d);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

/// The first and last grid cell of an edge's slightly grown bounding box.
fn edge_cells(grid: &UniformGrid, edge: &Edge) -> (Key, Key) {
    let pad = DVec2::splat(1e-9 * grid.cell_size());
    (
        grid.key(edge.a.min(edge.b) - pad),
        grid.key(edge.a.max(edge.b) + pad),
    )
}

/// The point where segments `a`-`b` and `c`-`d` cross, if they do (touching
/// at end points counts: the point is returned too).
fn proper_crossing(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> Option<DVec2> {
    let r = b - a;
    let s = d - c;
    let den = r.perp_dot(s);
    if den == 0.0 {
        return None;
    }
    let t = (c - a).perp_dot(s) / den;
    let u = (c - a).perp_dot(r) / den;
    ((0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u)).then(|| a + r * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Polygon;

    fn square(id: &str, x0: f64, y0: f64, s: f64) -> Building {
        Building {
            id: id.into(),
            footprint: vec![Polygon {
                exterior: vec![
                    DVec2::new(x0, y0),
                    DVec2::new(x0 + s, y0),
                    DVec2::new(x0 + s, y0 + s),
                    DVec2::new(x0, y0 + s),
                ],
                holes: vec![],
            }],
            height: 10.0,
            occludes: true,
        }
    }

    /// The walk finds the same crossings, in the same order, as testing
    /// every edge.
    #[test]
    fn walk_matches_brute_force() {
        let mut buildings = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                buildings.push(square(
                    &format!("{i},{j}"),
                    i as f64 * 13.7,
                    j as f64 * 11.3,
                    5.0 + ((i * 7 + j * 3) % 5) as f64,
                ));
            }
        }
        let grid = EdgeGrid::new(&buildings);
        let mut scratch = RayScratch::default();
        let mut total = 0;
        for k in 0..97 {
            let angle = k as f64 * 0.0731 + 0.01;
            let dir = DVec2::new(angle.cos(), angle.sin());
            let origin = DVec2::new(-20.0 + k as f64 * 3.1, 100.0 - k as f64 * 1.7);
            let mut walked = Vec::new();
            grid.walk(origin, dir, &mut scratch, |batch| {
                walked.extend(batch.iter().map(|c| (c.edge, c.t)));
                true
            });
            let mut brute: Vec<(u32, f64)> = grid
                .edges
                .iter()
                .enumerate()
                .filter_map(|(e, edge)| {
                    let sa = dir.perp_dot(edge.a - origin);
                    let sb = dir.perp_dot(edge.b - origin);
                    if (sa > 0.0) == (sb > 0.0) {
                        return None;
                    }
                    let p = edge.a + (edge.b - edge.a) * (sa / (sa - sb));
                    let t = (p - origin).dot(dir);
                    (t > 0.0).then_some((e as u32, t))
                })
                .collect();
            brute.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            assert_eq!(walked, brute, "ray {k}");
            total += walked.len();
        }
        assert!(total > 500, "the rays cross the city: {total}");
    }

    #[test]
    fn crossings_between_overlapping_buildings() {
        // Two overlapping squares cross at (5, 3) and (3, 5); a third one
        // touching the first along a wall adds its shared corners only.
        let city = vec![
            square("a", 0.0, 0.0, 5.0),
            square("b", 3.0, 3.0, 5.0),
            square("c", 5.0, -5.0, 5.0),
        ];
        let grid = EdgeGrid::new(&city);
        let points = grid.crossings_between_buildings();
        for p in [DVec2::new(3.0, 5.0), DVec2::new(5.0, 3.0)] {
            assert!(points.iter().any(|q| q.distance(p) < 1e-12), "{points:?}");
        }
        assert!(
            points
                .iter()
                .all(|q| q.x == 3.0 || q.x == 5.0 || q.y == 0.0 || q.y == 5.0),
            "{points:?}"
        );
    }

    /// Long diagonal edges each touch a whole row and column of grid cells;
    /// the edge lists are counted and the grid coarsened before they are
    /// allocated, and every edge is still listed wherever it passes.
    #[test]
    fn long_diagonal_edges_keep_the_edge_lists_bounded() {
        let sliver = |k: usize| {
            let o = k as f64 * 0.01;
            Building {
                id: format!("s{k}"),
                footprint: vec![Polygon {
                    exterior: vec![
                        DVec2::new(o, 0.0),
                        DVec2::new(o + 0.005, 0.0),
                        DVec2::new(o + 10_000.005, 10_000.0),
                        DVec2::new(o + 10_000.0, 10_000.0),
                    ],
                    holes: vec![],
                }],
                height: 10.0,
                occludes: true,
            }
        };
        let buildings: Vec<Building> = (0..2000).map(sliver).collect();
        let grid = EdgeGrid::new(&buildings);
        let limit = 16 * grid.edges.len() + 4_000_000;
        assert!(
            grid.lists.entries() <= limit,
            "{} items",
            grid.lists.entries()
        );
        // The ray along the diagonal still meets the first sliver's edges.
        let mut scratch = RayScratch::default();
        let mut hits = Vec::new();
        grid.walk(
            DVec2::new(-1.0, 5_000.0),
            DVec2::new(1.0, 0.0),
            &mut scratch,
            |batch| {
                hits.extend(batch.iter().map(|c| c.building));
                true
            },
        );
        assert!(hits.contains(&0), "{hits:?}");
    }
}
