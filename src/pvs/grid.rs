//! A uniform grid over the cell triangles, built when a file is opened, that
//! answers "which cell holds this point" by testing only the triangles whose
//! bounding boxes overlap the point's grid square.

use glam::DVec2;

/// Grid squares list the triangles whose bounding box overlaps them (CSR layout).
pub struct CellGrid {
    min: DVec2,
    size: DVec2,
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    items: Vec<u32>,
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
                min: DVec2::ZERO,
                size: DVec2::ZERO,
                nx: 0,
                ny: 0,
                starts: vec![0],
                items: Vec::new(),
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
        // Huge triangles would list themselves in many squares: coarsen until
        // the lists stay small (a corrupt file cannot make us allocate much).
        let limit = 16 * count as u64 + 1024;
        loop {
            let g = CellGrid {
                min,
                size,
                nx,
                ny,
                starts: Vec::new(),
                items: Vec::new(),
            };
            let total: u64 = (0..count)
                .map(|c| {
                    let (x0, y0, x1, y1) = g.square_range(&tri(c));
                    ((x1 - x0 + 1) * (y1 - y0 + 1)) as u64
                })
                .sum();
            if total <= limit || (nx == 1 && ny == 1) {
                return g.filled(count, &tri);
            }
            nx = nx.div_ceil(2);
            ny = ny.div_ceil(2);
        }
    }

    fn column(&self, x: f64) -> usize {
        let f = if self.size.x > 0.0 {
            (x - self.min.x) / self.size.x * self.nx as f64
        } else {
            0.0
        };
        (f.max(0.0) as usize).min(self.nx - 1)
    }

    fn row(&self, y: f64) -> usize {
        let f = if self.size.y > 0.0 {
            (y - self.min.y) / self.size.y * self.ny as f64
        } else {
            0.0
        };
        (f.max(0.0) as usize).min(self.ny - 1)
    }

    fn square_range(&self, t: &[DVec2; 3]) -> (usize, usize, usize, usize) {
        let lo = t[0].min(t[1]).min(t[2]);
        let hi = t[0].max(t[1]).max(t[2]);
        (
            self.column(lo.x),
            self.row(lo.y),
            self.column(hi.x),
            self.row(hi.y),
        )
    }

    fn filled(mut self, count: usize, tri: &impl Fn(usize) -> [DVec2; 3]) -> CellGrid {
        let squares = self.nx * self.ny;
        let mut counts = vec![0u32; squares + 1];
        for c in 0..count {
            let (x0, y0, x1, y1) = self.square_range(&tri(c));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    counts[y * self.nx + x + 1] += 1;
                }
            }
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[squares] as usize];
        for c in 0..count {
            let (x0, y0, x1, y1) = self.square_range(&tri(c));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let s = y * self.nx + x;
                    items[fill[s] as usize] = c as u32;
                    fill[s] += 1;
                }
            }
        }
        self.starts = counts;
        self.items = items;
        self
    }

    /// The lowest-numbered cell containing `p`, if any.
    pub fn find(&self, p: DVec2, tri: impl Fn(usize) -> [DVec2; 3]) -> Option<usize> {
        if self.nx == 0 || !p.is_finite() {
            return None;
        }
        let max = self.min + self.size;
        if p.x < self.min.x || p.y < self.min.y || p.x > max.x || p.y > max.y {
            return None;
        }
        let s = self.row(p.y) * self.nx + self.column(p.x);
        self.items[self.starts[s] as usize..self.starts[s + 1] as usize]
            .iter()
            .map(|&c| c as usize)
            .find(|&c| triangle_contains(&tri(c), p))
    }
}
