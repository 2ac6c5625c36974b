//! A triangular lattice of points over the open parts of free space, kept
//! clear of the outlines, and the bucket grid of outline segments that
//! answers "is any outline this close?".

use glam::DVec2;

use crate::grid::{CellLists, UniformGrid};
use crate::model::{MultiPolygon, Rect, distance_to_segment, polygon_edges};

/// Most buckets the segment grid may have (it coarsens beyond).
const MAX_BUCKETS: f64 = 1e6;

/// Points of a triangular lattice with the given spacing over the bounding
/// box of `free`, row by row, that are at least `clearance` from every
/// outline of `free` and that `keep` accepts (the caller decides what is
/// inside free space). The lattice is an optimisation only: none when it
/// would have more than `max_sites` sites.
pub fn lattice_points(
    free: &MultiPolygon,
    spacing: f64,
    clearance: f64,
    max_sites: usize,
    mut keep: impl FnMut(DVec2) -> bool,
) -> Vec<DVec2> {
    let bounds = Rect::of_points(free.iter().flat_map(|p| p.exterior.iter()));
    if bounds.is_empty() || spacing.is_nan() || spacing <= 0.0 {
        return Vec::new();
    }
    let row = spacing * 3f64.sqrt() / 2.0;
    let sites = (bounds.width() / spacing + 1.0) * (bounds.height() / row + 1.0);
    if sites.is_nan() || sites > max_sites as f64 {
        return Vec::new();
    }
    let outlines = SegmentGrid::new(free, bounds, clearance);
    let rows = (bounds.height() / row).floor() as usize;
    let mut points = Vec::new();
    for j in 0..=rows {
        let y = bounds.min.y + j as f64 * row;
        let shift = if j % 2 == 1 { 0.5 * spacing } else { 0.0 };
        let columns = ((bounds.width() - shift) / spacing).floor() as usize;
        for i in 0..=columns {
            let p = DVec2::new(bounds.min.x + shift + i as f64 * spacing, y);
            if !outlines.any_within(p, clearance) && keep(p) {
                points.push(p);
            }
        }
    }
    points
}

/// The outline segments bucketed on a uniform grid.
struct SegmentGrid {
    segments: Vec<(DVec2, DVec2)>,
    grid: UniformGrid,
    lists: CellLists,
}

impl SegmentGrid {
    /// Buckets at least `min_size` wide (and few enough) from the lower left
    /// corner of `bounds`, covering it.
    fn new(free: &MultiPolygon, bounds: Rect, min_size: f64) -> SegmentGrid {
        let mut size = min_size
            .max((bounds.width() * bounds.height() / MAX_BUCKETS).sqrt())
            .max(1e-9);
        // Checked before allocating, also for long thin or huge bounds.
        let buckets =
            |s: f64| (bounds.width() / s).ceil().max(1.0) * (bounds.height() / s).ceil().max(1.0);
        while buckets(size) > MAX_BUCKETS {
            size *= 2.0;
        }
        let (nx, ny) = UniformGrid::cells_to_cover(&bounds, size);
        let grid = UniformGrid::square(bounds.min, size, nx, ny);
        let segments: Vec<(DVec2, DVec2)> = free.iter().flat_map(polygon_edges).collect();
        let lists = CellLists::build(&grid, segments.len(), |k| {
            let (a, b) = segments[k];
            (grid.key(a.min(b)), grid.key(a.max(b)))
        });
        SegmentGrid {
            segments,
            grid,
            lists,
        }
    }

    /// Whether any segment comes closer than `distance` to `p`.
    fn any_within(&self, p: DVec2, distance: f64) -> bool {
        let g = &self.grid;
        let reach = (distance / g.cell_size()).ceil() as usize;
        let (cx, cy) = g.key(p);
        let lo = (cx.saturating_sub(reach), cy.saturating_sub(reach));
        let hi = ((cx + reach).min(g.nx() - 1), (cy + reach).min(g.ny() - 1));
        let mut found = false;
        g.for_each_in_range((lo, hi), |k| {
            found = found
                || self.lists.get(k).iter().any(|&s| {
                    let (a, b) = self.segments[s as usize];
                    distance_to_segment(p, a, b) < distance
                });
        });
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long thin strip of free space gets at most MAX_BUCKETS buckets
    /// (the area-based size alone would give millions of columns).
    #[test]
    fn segment_grid_of_a_long_thin_strip_stays_bounded() {
        let strip = vec![Polygon {
            exterior: vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(1e7, 0.0),
                DVec2::new(1e7, 1.0),
                DVec2::new(0.0, 1.0),
            ],
            holes: vec![],
        }];
        let bounds = Rect::of_points(strip[0].exterior.iter());
        let grid = SegmentGrid::new(&strip, bounds, 0.01);
        assert!(
            grid.grid.len() as f64 <= MAX_BUCKETS,
            "{} x {}",
            grid.grid.nx(),
            grid.grid.ny()
        );
        assert!(grid.any_within(DVec2::new(5e6, 0.5), 0.6));
        assert!(!grid.any_within(DVec2::new(5e6, 0.5), 0.4));
    }
    use crate::model::Polygon;

    #[test]
    fn lattice_keeps_clear_of_outlines() {
        let square = |x0: f64, y0: f64, s: f64| {
            vec![
                DVec2::new(x0, y0),
                DVec2::new(x0 + s, y0),
                DVec2::new(x0 + s, y0 + s),
                DVec2::new(x0, y0 + s),
            ]
        };
        let mut hole = square(40.0, 40.0, 20.0);
        hole.reverse();
        let free = vec![Polygon {
            exterior: square(0.0, 0.0, 100.0),
            holes: vec![hole],
        }];
        let points = lattice_points(&free, 10.0, 7.0, 1000, |_| true);
        assert!(lattice_points(&free, 10.0, 7.0, 100, |_| true).is_empty());
        let right = lattice_points(&free, 10.0, 7.0, 1000, |p| p.x > 50.0);
        assert!(!right.is_empty() && right.len() < points.len());
        assert!(!points.is_empty());
        let edges: Vec<_> = polygon_edges(&free[0]).collect();
        for p in &points {
            let d = edges
                .iter()
                .map(|&(a, b)| distance_to_segment(*p, a, b))
                .fold(f64::INFINITY, f64::min);
            assert!(d >= 7.0);
        }
        // Brute force agrees on the count of lattice sites kept.
        let row = 10.0 * 3f64.sqrt() / 2.0;
        let mut expected = 0;
        for j in 0..=((100.0 / row) as usize) {
            let shift = if j % 2 == 1 { 5.0 } else { 0.0 };
            for i in 0..=(((100.0 - shift) / 10.0) as usize) {
                let p = DVec2::new(shift + i as f64 * 10.0, j as f64 * row);
                let d = edges
                    .iter()
                    .map(|&(a, b)| distance_to_segment(p, a, b))
                    .fold(f64::INFINITY, f64::min);
                expected += usize::from(d >= 7.0);
            }
        }
        assert_eq!(points.len(), expected);
    }
}
