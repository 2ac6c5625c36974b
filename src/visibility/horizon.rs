//! The per-sample horizon (METHOD.md 6): for each azimuth bin, a lower bound
//! on the steepest sight-line slope (rise over run) blocked by the shrunk
//! occluders inside the cull-map window, valid for EVERY direction in the
//! bin. Anything wholly outside the window whose own steepest slope is at or
//! below the horizon over all its bins is hidden.
//!
//! Why the bound holds: a connected chain of occluder edges at height H maps
//! onto a connected arc of directions seen from the eye, so every direction
//! in that arc meets the chain, at a distance no greater than the chain's
//! farthest vertex d. Where it meets it, solid stands up to H, so the sight
//! line in that direction is blocked up to slope (H - h) / d. Only bins that
//! lie wholly inside such an arc get the bound; a ray from the eye meets the
//! window's occluders before anything outside the window.

use std::f64::consts::{PI, TAU};

use glam::DVec2;

use crate::model::Rect;

/// Number of azimuth bins.
pub const BINS: usize = 2048;
const BIN_WIDTH: f64 = TAU / BINS as f64;
/// Chains grow until their arc spans this many bins or this many edges.
const CHAIN_MIN_BINS: f64 = 3.0;
const CHAIN_MAX_EDGES: usize = 8;

/// Per-bin lower bounds on the blocked slope, `-inf` where nothing is known.
#[derive(Clone, Debug)]
pub struct Horizon {
    slopes: Vec<f64>,
}

impl Default for Horizon {
    fn default() -> Self {
        Horizon {
            slopes: vec![f64::NEG_INFINITY; BINS],
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
    }

    /// Raise the bins that lie wholly inside the arc `[lo, hi]` (unwrapped
    /// radians) to at least `slope`.
    fn raise_arc(&mut self, lo: f64, hi: f64, slope: f64) {
        if hi - lo >= TAU {
            for s in &mut self.slopes {
                *s = s.max(slope);
            }
            return;
        }
        let first = ((lo + PI) / BIN_WIDTH).ceil() as i64;
        let last = ((hi + PI) / BIN_WIDTH).floor() as i64 - 1;
        for b in first..=last {
            let s = &mut self.slopes[b.rem_euclid(BINS as i64) as usize];
            *s = s.max(slope);
        }
    }

    /// Add a chain of connected occluder edges at `height`, given by its
    /// vertices in order. It is used edge by edge, each prefix raising the
    /// bins wholly inside its arc, until it has at least two edges and its
    /// arc covers a few bins (or it reaches the edge limit).
    pub fn add_chain(
        &mut self,
        v: DVec2,
        eye: f64,
        height: f64,
        points: impl Iterator<Item = DVec2>,
    ) {
        if height <= eye {
            return;
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut reference = 0.0;
        let mut d_max: f64 = 0.0;
        let mut edges = 0usize;
        for (idx, p) in points.enumerate() {
            let d = p.distance(v);
            if d < 1e-9 {
                return;
            }
            let a = if idx == 0 {
                unwrapped_angle(v, p, 0.0)
            } else {
                unwrapped_angle(v, p, reference)
            };
            reference = a;
            lo = lo.min(a);
            hi = hi.max(a);
            d_max = d_max.max(d);
            if idx > 0 {
                edges += 1;
                self.raise_arc(lo, hi, (height - eye) / d_max);
                // At least two edges, so the bins around the shared vertex are covered.
                if (edges >= 2 && (hi - lo) >= CHAIN_MIN_BINS * BIN_WIDTH)
                    || edges >= CHAIN_MAX_EDGES
                {
                    return;
                }
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
        for i in 0..pts.len() - 1 {
            h.add_chain(DVec2::ZERO, 2.0, 10.0, pts[i..].iter().copied());
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
