//! A uniform grid over the cell triangles, built when a file is opened, that
//! answers "which cell holds this point" by testing only the triangles whose
//! bounding boxes overlap the point's grid square, and for a point in none
//! of them, which cell within the corners' snap distance is nearest.

use glam::DVec2;

use crate::grid::{CellLists, Key, UniformGrid};
use crate::model::{Rect, distance_to_segment};

/// Grid squares list the triangles whose bounding box overlaps them.
pub struct CellGrid {
    /// The bounding box of the triangles; none when there are none.
    bounds: Option<(DVec2, DVec2)>,
    grid: UniformGrid,
    lists: CellLists,
}

fn cross(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    (b - a).perp_dot(p - a)
}

/// Whether `p` lies in the triangle or on its boundary (either orientation).
/// Degenerate (zero-area) triangles hold no point.
pub fn triangle_contains(t: &[DVec2; 3], p: DVec2) -> bool {
    let area = cross(t[0], t[1], t[2]);
    if area == 0.0 {
        return false;
    }
    let s = area.signum();
    (0..3).all(|k| cross(t[k], t[(k + 1) % 3], p) * s >= 0.0)
}

/// Distance from `p` to the triangle (0 inside or on it; a flat triangle
/// is its edges).
pub fn distance_to_triangle(t: &[DVec2; 3], p: DVec2) -> f64 {
    if triangle_contains(t, p) {
        return 0.0;
    }
    (0..3)
        .map(|k| distance_to_segment(p, t[k], t[(k + 1) % 3]))
        .fold(f64::INFINITY, f64::min)
}

/// The key range of a triangle's bounding box.
fn square_range(grid: &UniformGrid, t: &[DVec2; 3]) -> (Key, Key) {
    (
        grid.key(t[0].min(t[1]).min(t[2])),
        grid.key(t[0].max(t[1]).max(t[2])),
    )
}

impl CellGrid {
    /// The grid over `count` triangles, triangle `c` being `tri(c)`.
    pub fn new(count: usize, tri: impl Fn(usize) -> [DVec2; 3]) -> CellGrid {
        let mut min = DVec2::splat(f64::INFINITY);
        let mut max = DVec2::splat(f64::NEG_INFINITY);
        for c in 0..count {
            for p in tri(c) {
                min = min.min(p);
                max = max.max(p);
            }
        }
        if count == 0 {
            return CellGrid {
                bounds: None,
                grid: UniformGrid::square(DVec2::ZERO, 1.0, 1, 1),
                lists: CellLists::none(),
            };
        }
        let size = max - min;
        // About one square per cell, squares as square as the bounds allow.
        let target = (count as f64).max(1.0);
        let aspect = if size.y > 0.0 && size.x > 0.0 {
            size.x / size.y
        } else {
            1.0
        };
        let mut nx = ((target * aspect).sqrt().ceil() as usize).clamp(1, 4096);
        let mut ny = ((target / aspect).sqrt().ceil() as usize).clamp(1, 4096);
        // The grid's `nx` by `ny` squares span the bounding box exactly (a
        // flat box gets one square across).
        let grid_of = |nx: usize, ny: usize| {
            let side = |extent: f64, n: usize| if extent > 0.0 { extent / n as f64 } else { 1.0 };
            UniformGrid::new(min, DVec2::new(side(size.x, nx), side(size.y, ny)), nx, ny)
        };
        // Huge triangles would list themselves in many squares: coarsen until
        // the lists stay small (a corrupt file cannot make us allocate much).
        let limit = 16 * count as u64 + 1024;
        loop {
            let g = grid_of(nx, ny);
            let total = CellLists::total(&g, count, |c| square_range(&g, &tri(c)));
            if total <= limit || (nx == 1 && ny == 1) {
                return CellGrid {
                    bounds: Some((min, max)),
                    grid: g,
                    lists: CellLists::build(&g, count, |c| square_range(&g, &tri(c))),
                };
            }
            nx = nx.div_ceil(2);
            ny = ny.div_ceil(2);
        }
    }

    /// The lowest-numbered cell containing `p`; if none does, the nearest
    /// cell within `reach` of `p` (ties: the lowest-numbered), if any.
    pub fn find(&self, p: DVec2, reach: f64, tri: impl Fn(usize) -> [DVec2; 3]) -> Option<usize> {
        let (min, max) = self.bounds?;
        let outside =
            |d: f64| p.x < min.x - d || p.y < min.y - d || p.x > max.x + d || p.y > max.y + d;
        if !p.is_finite() || outside(reach) {
            return None;
        }
        if !outside(0.0) {
            let inside = self
                .lists
                .get(self.grid.index(self.grid.key(p)))
                .iter()
                .map(|&c| c as usize)
                .find(|&c| triangle_contains(&tri(c), p));
            if inside.is_some() {
                return inside;
            }
        }
        let near = Rect {
            min: p - DVec2::splat(reach),
            max: p + DVec2::splat(reach),
        };
        let mut best: Option<(f64, usize)> = None;
        self.grid.for_each_in_rect(&near, |square| {
            for &c in self.lists.get(square) {
                let d = distance_to_triangle(&tri(c as usize), p);
                if d <= reach
                    && best.is_none_or(|(bd, bc)| d < bd || (d == bd && (c as usize) < bc))
                {
                    best = Some((d, c as usize));
                }
            }
        });
        best.map(|(_, c)| c)
    }
}
