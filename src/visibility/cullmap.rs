//! The software cull map of one sample (docs/METHOD.md §5): a window of the global
//! pixel grid holding U_V, the max over shrunk occluder edges of the shadow
//! height at each pixel centre, and the conservative occludee test against
//! it. Heights are stored as f32 rounded down, so rounding only lowers a
//! shadow.

use glam::DVec2;

use super::index::{PixelGrid, Span};
use crate::model::{Rect, cut_points, piece_count};

/// Pixel centres closer than this (metres) to a shadow quad's border are
/// left out of it, so floating-point rounding never extends a shadow.
const BORDER_TOLERANCE: f64 = 1e-7;

/// A rectangular window `[i0, i0 + width) x [j0, j0 + height)` of the global
/// pixel grid with one shadow height per pixel.
#[derive(Clone, Debug)]
pub struct CullWindow {
    pub grid: PixelGrid,
    pub i0: i32,
    pub j0: i32,
    pub width: usize,
    pub height: usize,
    pub heights: Vec<f32>,
}

/// The largest f32 not above `v`.
pub fn f32_down(v: f64) -> f32 {
    let f = v as f32;
    if f as f64 > v { f.next_down() } else { f }
}

impl CullWindow {
    pub fn new(grid: PixelGrid) -> Self {
        CullWindow {
            grid,
            i0: 0,
            j0: 0,
            width: 0,
            height: 0,
            heights: Vec::new(),
        }
    }

    /// Cover the square of half-size `radius` around `centre` (whole pixels),
    /// every pixel at 0 (nothing hidden).
    pub fn reset_around(&mut self, centre: DVec2, radius: f64) {
        let (i0, j0) = self.grid.pixel_of(centre - DVec2::splat(radius));
        let (i1, j1) = self.grid.pixel_of(centre + DVec2::splat(radius));
        self.reset(i0, j0, (i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    }

    /// Place the window over the square of half-size `radius` around
    /// `centre` (as `reset_around`) without touching the heights: call
    /// `clear_heights` before drawing.
    pub fn place_around(&mut self, centre: DVec2, radius: f64) {
        let (i0, j0) = self.grid.pixel_of(centre - DVec2::splat(radius));
        let (i1, j1) = self.grid.pixel_of(centre + DVec2::splat(radius));
        self.i0 = i0;
        self.j0 = j0;
        self.width = (i1 - i0 + 1) as usize;
        self.height = (j1 - j0 + 1) as usize;
    }

    /// Every pixel at 0 (nothing hidden).
    pub fn clear_heights(&mut self) {
        self.heights.clear();
        self.heights.resize(self.width * self.height, 0.0);
    }

    /// Cover the given pixels, every pixel at 0.
    pub fn reset(&mut self, i0: i32, j0: i32, width: usize, height: usize) {
        self.i0 = i0;
        self.j0 = j0;
        self.width = width;
        self.height = height;
        self.heights.clear();
        self.heights.resize(width * height, 0.0);
    }

    /// The window's area in local metres.
    pub fn rect(&self) -> Rect {
        let k = self.grid.pixel;
        Rect {
            min: DVec2::new(self.i0 as f64 * k, self.j0 as f64 * k),
            max: DVec2::new(
                (self.i0 + self.width as i32) as f64 * k,
                (self.j0 + self.height as i32) as f64 * k,
            ),
        }
    }

    /// Shadow height at the pixel containing `p`, or None outside the window.
    pub fn at_point(&self, p: DVec2) -> Option<f32> {
        let (i, j) = self.grid.pixel_of(p);
        let (x, y) = (i - self.i0, j - self.j0);
        if x < 0 || y < 0 || x as usize >= self.width || y as usize >= self.height {
            return None;
        }
        Some(self.heights[y as usize * self.width + x as usize])
    }

    /// Raise the map to the shadow of the occluder edge `a`-`b` at `height`
    /// seen from `(v, eye)`: the quad `a, b, b + s(b - v), a + s(a - v)`
    /// under the plane through the eye and the edge's top.
    pub fn rasterise_shadow(&mut self, v: DVec2, eye: f64, a: DVec2, b: DVec2, height: f64) {
        let (mut a, mut b) = (a, b);
        if (a - v).perp_dot(b - v) < 0.0 {
            std::mem::swap(&mut a, &mut b);
        }
        let dir = b - a;
        let len = dir.length();
        if len <= 0.0 {
            return;
        }
        // Unit normal of the edge pointing away from the eye.
        let mut n = DVec2::new(dir.y, -dir.x) / len;
        let mut dist_to_line = (a - v).dot(n);
        if dist_to_line < 0.0 {
            n = -n;
            dist_to_line = -dist_to_line;
        }
        if dist_to_line <= BORDER_TOLERANCE {
            return;
        }
        let ua = (a - v).normalize();
        let ub = (b - v).normalize();
        // Three half-planes c.x * x + c.y * y + c.z >= tol (in metres):
        // beyond the edge line, left of the ray to a, right of the ray to b.
        let planes = [
            (n, -(v.dot(n) + dist_to_line)),
            (DVec2::new(-ua.y, ua.x), -DVec2::new(-ua.y, ua.x).dot(v)),
            (DVec2::new(ub.y, -ub.x), -DVec2::new(ub.y, -ub.x).dot(v)),
        ];
        let rise = (height - eye) / dist_to_line;
        let k = self.grid.pixel;
        let (row_lo, row_hi) = self.shadow_rows(v, a, b, ua, ub);
        for row in row_lo..row_hi {
            let yc = (self.j0 + row as i32) as f64 * k + 0.5 * k;
            let (mut x_lo, mut x_hi) = (f64::NEG_INFINITY, f64::INFINITY);
            let mut empty = false;
            for (c, off) in planes {
                let rest = c.y * yc + off - BORDER_TOLERANCE;
                if c.x.abs() < 1e-15 {
                    if rest < 0.0 {
                        empty = true;
                    }
                } else if c.x > 0.0 {
                    x_lo = x_lo.max(-rest / c.x);
                } else {
                    x_hi = x_hi.min(-rest / c.x);
                }
            }
            if empty || x_lo > x_hi {
                continue;
            }
            let i_start = ((x_lo / k - 0.5).ceil() as i64).max(self.i0 as i64);
            let i_end =
                ((x_hi / k - 0.5).floor() as i64).min(self.i0 as i64 + self.width as i64 - 1);
            if i_start > i_end {
                continue;
            }
            let base = row * self.width;
            for i in i_start..=i_end {
                let xc = i as f64 * k + 0.5 * k;
                let d = (DVec2::new(xc, yc) - v).dot(n);
                let shadow = eye + rise * d;
                if shadow > 0.0 {
                    let cell = &mut self.heights[base + (i - self.i0 as i64) as usize];
                    let s = f32_down(shadow);
                    if s > *cell {
                        *cell = s;
                    }
                }
            }
        }
    }

    /// Rows `lo..hi` of the window outside which the shadow quad of `a`-`b`
    /// seen from `v` (unit directions `ua`, `ub` to its ends) has no pixel:
    /// inside the window every point is within `reach` of `v`, so the part
    /// of the quad there lies in the quad cut off where the rays to a and b
    /// are `reach / cos(half the wedge's angle)` long, and the rows are those
    /// of its four corners, one row of margin either side.
    fn shadow_rows(&self, v: DVec2, a: DVec2, b: DVec2, ua: DVec2, ub: DVec2) -> (usize, usize) {
        let k = self.grid.pixel;
        let full = (0, self.height);
        let r = self.rect();
        let reach = [
            r.min,
            r.max,
            DVec2::new(r.min.x, r.max.y),
            DVec2::new(r.max.x, r.min.y),
        ]
        .iter()
        .map(|c| c.distance(v))
        .fold(0.0, f64::max);
        let mid = ua + ub;
        let cos_half = mid.length() / 2.0;
        if cos_half.is_nan() || cos_half <= 1e-3 {
            return full;
        }
        let far = reach / cos_half + 2.0 * k;
        let (ta, tb) = (far.max(a.distance(v)), far.max(b.distance(v)));
        let ys = [a.y, b.y, v.y + ua.y * ta, v.y + ub.y * tb];
        let y_lo = ys.iter().copied().fold(f64::INFINITY, f64::min);
        let y_hi = ys.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lo = ((y_lo / k).floor() - 1.0 - self.j0 as f64).max(0.0);
        let hi = ((y_hi / k).floor() + 2.0 - self.j0 as f64).min(self.height as f64);
        if lo.is_nan() || hi.is_nan() || lo >= hi {
            return (0, 0);
        }
        (lo as usize, hi as usize)
    }

    /// True when the map hides height `top` at the pixels under points along
    /// the segment `a`-`b` (a test for dropping occluded occluders; dropping
    /// any occluder is always conservative).
    pub fn segment_hidden(&self, a: DVec2, b: DVec2, top: f64) -> bool {
        let steps = piece_count(a, b, 0.5 * self.grid.pixel);
        cut_points(a, b, steps).all(|p| match self.at_point(p) {
            Some(u) => u as f64 >= top,
            None => false,
        })
    }

    /// Test an object's pixels that fall inside the window: false as soon as
    /// one has a shadow lower than `top`. Pixels outside the window are not
    /// looked at; `outside` is set when there are any.
    pub fn spans_hidden(&self, spans: &[Span], top: f64, outside: &mut bool) -> bool {
        let (i_end, j_end) = (self.i0 + self.width as i32, self.j0 + self.height as i32);
        for s in spans {
            if s.j < self.j0 || s.j >= j_end {
                *outside = true;
                continue;
            }
            if s.i0 < self.i0 || s.i1 > i_end {
                *outside = true;
            }
            let (lo, hi) = (s.i0.max(self.i0), s.i1.min(i_end));
            let row = &self.heights[(s.j - self.j0) as usize * self.width..];
            for i in lo..hi {
                if (row[(i - self.i0) as usize] as f64) < top {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wall_shadow_rises_behind_a_tall_wall() {
        let grid = PixelGrid { pixel: 1.0 };
        let mut w = CullWindow::new(grid);
        w.reset_around(DVec2::ZERO, 30.0);
        // Wall 10 m high along x = 5, eye at 2 m at the origin.
        w.rasterise_shadow(
            DVec2::ZERO,
            2.0,
            DVec2::new(5.0, -10.0),
            DVec2::new(5.0, 10.0),
            10.0,
        );
        // In front of the wall: nothing.
        assert_eq!(w.at_point(DVec2::new(2.5, 0.5)), Some(0.0));
        // At x = 10.5 the plane is at 2 + 8 * 10.5 / 5 = 18.8 m.
        let u = w.at_point(DVec2::new(10.2, 0.2)).unwrap();
        assert!((u as f64 - 18.8).abs() < 1e-4 && (u as f64) <= 18.8, "{u}");
        // Outside the wedge (beyond y = 2 * x): nothing.
        assert_eq!(w.at_point(DVec2::new(6.5, 20.5)), Some(0.0));
    }

    proptest::proptest! {
        /// The solver draws only the edges whose box meets the window: an
        /// edge beyond one of its sides (every edge whose box misses it
        /// is) must cast no shadow into it, seen from an eye inside it.
        #[test]
        fn an_edge_outside_the_window_casts_no_shadow_into_it(
            eye in proptest::array::uniform2(-50.0f64..50.0),
            radius in 2.0f64..20.0,
            side in 0usize..4,
            along in proptest::array::uniform2(-80.0f64..80.0),
            out in proptest::array::uniform2(0.0f64..40.0),
            height in 0.5f64..60.0,
        ) {
            let v = DVec2::from(eye);
            let mut w = CullWindow::new(PixelGrid { pixel: 0.5 });
            w.reset_around(v, radius);
            let r = w.rect();
            let end = |t: f64, o: f64| match side {
                0 => DVec2::new(r.max.x + 1e-9 + o, v.y + t),
                1 => DVec2::new(r.min.x - 1e-9 - o, v.y + t),
                2 => DVec2::new(v.x + t, r.max.y + 1e-9 + o),
                _ => DVec2::new(v.x + t, r.min.y - 1e-9 - o),
            };
            let (a, b) = (end(along[0], out[0]), end(along[1], out[1]));
            w.rasterise_shadow(v, 1.7, a, b, height);
            proptest::prop_assert!(w.heights.iter().all(|&u| u == 0.0));
        }
    }

    #[test]
    fn rounding_goes_down() {
        for v in [0.1f64, 1.0 / 3.0, 18.8, 1e-9, 12345.678] {
            assert!((f32_down(v) as f64) <= v);
        }
    }
}
