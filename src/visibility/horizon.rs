//! The per-sample horizon (METHOD.md 6): for each azimuth bin, a lower bound
//! on the steepest sight-line slope (rise over run) blocked by the shrunk
//! occluders inside the cull-map window, valid for EVERY direction in the
//! bin. Anything wholly outside the window whose own steepest slope is at or
//! below the horizon over all its bins is hidden.
//!
//! Why the bound holds: a connected chain of occluder edges at height H maps
//! onto a connected arc of directions seen from the eye, so every direction
//! in that arc meets the chain. Within one bin's wedge, it meets it no
//! farther than d, the greatest distance of the chain's parts inside the
//! wedge (on a straight edge the distance is convex, so it is greatest at
//! the wedge's borders or the edge's ends). Where it meets it, solid stands
//! up to H, so the sight line in that direction is blocked up to slope
//! (H - h) / d. Only bins that lie wholly inside a chain's arc get the bound.
//! The solver only uses chains that lie wholly nearer than the object tested,
//! so the blocking point is in front of it.

use std::f64::consts::{PI, TAU};

use glam::DVec2;

use crate::model::Rect;

/// Number of azimuth bins.
pub const BINS: usize = 2048;
const BIN_WIDTH: f64 = TAU / BINS as f64;
/// Bins per group in the coarse level that lets hidden chains be skipped.
const GROUP: usize = 32;

/// Per-bin lower bounds on the blocked slope, `-inf` where nothing is known.
#[derive(Clone, Debug)]
pub struct Horizon {
    slopes: Vec<f64>,
    chain_points: Vec<DVec2>,
    chain_angles: Vec<f64>,
    bin_distance: Vec<f64>,
    /// Unit direction of each bin's lower border, `border_dirs[b]` at angle
    /// `b * BIN_WIDTH - pi`.
    border_dirs: Vec<DVec2>,
    /// Per group of GROUP bins, the smallest slope of its bins.
    group_min: Vec<f64>,
}

impl Default for Horizon {
    fn default() -> Self {
        Horizon {
            slopes: vec![f64::NEG_INFINITY; BINS],
            chain_points: Vec::new(),
            chain_angles: Vec::new(),
            bin_distance: Vec::new(),
            border_dirs: (0..BINS)
                .map(|b| {
                    let theta = b as f64 * BIN_WIDTH - PI;
                    DVec2::new(theta.cos(), theta.sin())
                })
                .collect(),
            group_min: vec![f64::NEG_INFINITY; BINS / GROUP],
        }
    }
}

/// Angle of `p - v` unwrapped to lie within pi of `reference`.
fn unwrapped_angle(v: DVec2, p: DVec2, reference: f64) -> f64 {
    let d = p - v;
    let mut a = d.y.atan2(d.x);
    while a - reference > PI {
        a -= TAU;
    }
    while a - reference < -PI {
        a += TAU;
    }
    a
}

impl Horizon {
    pub fn clear(&mut self) {
        self.slopes.fill(f64::NEG_INFINITY);
        self.group_min.fill(f64::NEG_INFINITY);
    }

    /// Add a chain of connected occluder edges at `height`, given by its
    /// vertices in order (at least two edges, so the bins around each
    /// shared vertex are covered by some chain). Every bin wholly inside the
    /// chain's arc is raised to (height - eye) / d, where d is the greatest
    /// distance from the eye to the parts of the chain inside that bin's
    /// wedge: every ray of the bin meets the chain no farther than d.
    pub fn add_chain(&mut self, v: DVec2, eye: f64, height: f64, points: impl Iterator<Item = DVec2>) {
        if height <= eye {
            return;
        }
        self.chain_points.clear();
        self.chain_points.extend(points);
        let n = self.chain_points.len();
        if n < 2 {
            return;
        }
        self.chain_angles.clear();
        let mut reference = 0.0;
        for i in 0..n {
            let p = self.chain_points[i];
            if p.distance(v) < 1e-9 {
                return;
            }
            reference = unwrapped_angle(v, p, reference);
            self.chain_angles.push(reference);
        }
        let lo = self.chain_angles.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.chain_angles.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if hi - lo >= TAU {
            // The chain winds around the eye; keep it simple and skip it.
            return;
        }
        let base = ((lo + PI) / BIN_WIDTH).floor() as i64;
        let top = ((hi + PI) / BIN_WIDTH).floor() as i64;
        // The steepest slope this chain could give; if every bin it spans is
        // already at least that steep, it adds nothing.
        let nearest = self
            .chain_points
            .windows(2)
            .map(|w| crate::model::distance_to_segment(v, w[0], w[1]))
            .fold(f64::INFINITY, f64::min);
        let steepest = (height - eye) / nearest;
        let groups = (base.div_euclid(GROUP as i64)..=top.div_euclid(GROUP as i64))
            .map(|g| self.group_min[g.rem_euclid((BINS / GROUP) as i64) as usize]);
        if groups.fold(f64::INFINITY, f64::min) >= steepest {
            return;
        }
        self.bin_distance.clear();
        self.bin_distance.resize((top - base + 1) as usize, 0.0);
        for i in 0..n - 1 {
            let (a, b) = (self.chain_points[i], self.chain_points[i + 1]);
            let (mut ta, mut tb) = (self.chain_angles[i], self.chain_angles[i + 1]);
            let (mut da, mut db) = (a.distance(v), b.distance(v));
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
                std::mem::swap(&mut da, &mut db);
            }
            let normal = (b - a).perp();
            let offset = (a - v).dot(normal);
            let far = da.max(db);
            let dirs = &self.border_dirs;
            // Distance along the border ray of bin `border` to the edge's line,
            // capped by the edge's farther end (the border ray meets the edge
            // itself when the border lies strictly between its end angles).
            let along = |border: i64| -> f64 {
                let denom = dirs[border.rem_euclid(BINS as i64) as usize].dot(normal);
                let t = offset / denom;
                if denom.abs() < 1e-12 || !t.is_finite() || t <= 0.0 { far } else { t.min(far) }
            };
            let first = ((ta + PI) / BIN_WIDTH).floor() as i64;
            let last = ((tb + PI) / BIN_WIDTH).floor() as i64;
            // Distance at the lower border of each bin first..=last+1; the
            // borders outside [ta, tb] are replaced by the edge's ends.
            let mut lower = da;
            for bin in first..=last {
                let upper_border = bin + 1;
                let upper = if upper_border as f64 * BIN_WIDTH - PI >= tb { db } else { along(upper_border) };
                let slot = &mut self.bin_distance[(bin - base) as usize];
                *slot = slot.max(lower).max(upper);
                lower = upper;
            }
        }
        let first_full = ((lo + PI) / BIN_WIDTH).ceil() as i64;
        let last_full = ((hi + PI) / BIN_WIDTH).floor() as i64 - 1;
        for bin in first_full..=last_full {
            let d = self.bin_distance[(bin - base) as usize];
            if d > 0.0 {
                let s = &mut self.slopes[bin.rem_euclid(BINS as i64) as usize];
                *s = s.max((height - eye) / d);
            }
        }
        if first_full <= last_full {
            for g in first_full.div_euclid(GROUP as i64)..=last_full.div_euclid(GROUP as i64) {
                let g = g.rem_euclid((BINS / GROUP) as i64) as usize;
                let bins = &self.slopes[g * GROUP..(g + 1) * GROUP];
                self.group_min[g] = bins.iter().copied().fold(f64::INFINITY, f64::min);
            }
        }
    }

    /// True when everything in `rect` up to height `top` is below the
    /// horizon seen from `(v, eye)`. Only valid for the parts of `rect` that
    /// lie outside the window the horizon was built from.
    pub fn hides_rect(&self, v: DVec2, eye: f64, rect: &Rect, top: f64) -> bool {
        let nearest = v.clamp(rect.min, rect.max);
        let r_min = nearest.distance(v);
        if r_min < 1e-6 {
            return false;
        }
        let corners = [
            rect.min,
            DVec2::new(rect.max.x, rect.min.y),
            rect.max,
            DVec2::new(rect.min.x, rect.max.y),
        ];
        let need = if top >= eye {
            (top - eye) / r_min
        } else {
            let r_max = corners.iter().map(|c| c.distance(v)).fold(0.0, f64::max);
            (top - eye) / r_max
        };
        let reference = unwrapped_angle(v, corners[0], 0.0);
        let mut lo = reference;
        let mut hi = reference;
        for c in &corners[1..] {
            let a = unwrapped_angle(v, *c, reference);
            lo = lo.min(a);
            hi = hi.max(a);
        }
        let first = ((lo + PI) / BIN_WIDTH).floor() as i64;
        let last = ((hi + PI) / BIN_WIDTH).floor() as i64;
        (first..=last).all(|b| self.slopes[b.rem_euclid(BINS as i64) as usize] >= need)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_wall_hides_a_lower_house_behind_it_but_not_a_tower() {
        let mut h = Horizon::default();
        // Wall 10 m high along x = 10 from y = -50 to 50, in short edges.
        let pts = (0..=100).map(|i| DVec2::new(10.0, -50.0 + i as f64));
        let pts: Vec<DVec2> = pts.collect();
        for i in 0..pts.len() - 2 {
            h.add_chain(DVec2::ZERO, 2.0, 10.0, pts[i..i + 3].iter().copied());
        }
        let house = Rect {
            min: DVec2::new(30.0, -5.0),
            max: DVec2::new(40.0, 5.0),
        };
        assert!(h.hides_rect(DVec2::ZERO, 2.0, &house, 12.0));
        // Slope of the wall top: 8 / 10 at the nearest point, less along the wall;
        // a tower of 40 m at 30 m has slope 38 / 30 > 0.8.
        assert!(!h.hides_rect(DVec2::ZERO, 2.0, &house, 40.0));
        // Past the end of the wall (directions beyond 78.7 degrees): not hidden.
        let beside = Rect {
            min: DVec2::new(-10.0, 80.0),
            max: DVec2::new(0.0, 90.0),
        };
        assert!(!h.hides_rect(DVec2::ZERO, 2.0, &beside, 3.0));
    }
}
