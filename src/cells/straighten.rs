//! Straightened facade runs of the kept free space (docs/geometry.md
//! section 4, "Straight facades"): a run of outline vertices that all lie
//! within [`TOLERANCE`] x min_gap of one line becomes one straight edge on
//! the free side of all of them, so that the junctions of wall-sharing
//! buildings (facades off by a few centimetres) stop putting vertices, and
//! so small cells, into the free space. Only free space is removed: the
//! result is the old free space cut by the new outline.
//!
//! Owns the choice of runs, their lines and the new outline.

use geo::BooleanOps;
use glam::DVec2;

use crate::geometry::convert::{multipolygon_from_geo, multipolygon_to_geo};
use crate::model::{MultiPolygon, Polygon, Ring, ring_signed_area2};

/// Vertices within this fraction of min_gap of a line (6 cm by default) are
/// straightened to it: half of the largest facade offset of neighbours in
/// map data on each side of a chord, and far below min_gap / 2, the least
/// distance from a wall of a viewer's centre.
pub const TOLERANCE: f64 = 0.12;

/// A run's corner point may lie at most this many tolerances from the
/// vertex it replaces; farther (nearly parallel runs) the corner is put
/// between the two lines instead.
const CORNER_REACH: f64 = 3.0;

/// Longest run, in vertices.
const MAX_RUN: usize = 512;

/// The free space with every facade run straightened; nothing changes when
/// `min_gap <= 0`.
pub fn straighten(free: &MultiPolygon, min_gap: f64) -> MultiPolygon {
    if !(min_gap > 0.0) || free.is_empty() {
        return free.clone();
    }
    let tol = TOLERANCE * min_gap;
    let mut changed = false;
    let lines: MultiPolygon = free
        .iter()
        .map(|p| {
            let mut ring = |r: &Ring| match straight_ring(r, tol) {
                Some(new) => {
                    changed = true;
                    new
                }
                None => r.clone(),
            };
            Polygon {
                exterior: ring(&p.exterior),
                holes: p.holes.iter().map(&mut ring).collect(),
            }
        })
        .collect();
    if !changed {
        return free.clone();
    }
    // Keep only what lies on the free side of the new outline as well as
    // inside the old free space.
    let cut = multipolygon_to_geo(free).intersection(&multipolygon_to_geo(&lines));
    multipolygon_from_geo(&cut, 1e-4)
}

/// A run of the ring from vertex `start` to vertex `end` (indices modulo
/// the ring's length): the line through the chord shifted to the free side
/// (left) by `shift`.
struct Run {
    start: usize,
    end: usize,
    a: DVec2,
    dir: DVec2,
    normal: DVec2,
    shift: f64,
}

/// The straightened ring, or `None` when nothing changes.
fn straight_ring(ring: &[DVec2], tol: f64) -> Option<Ring> {
    let n = ring.len();
    if n < 4 {
        return None;
    }
    let at = |i: usize| ring[i % n];
    // Start at the sharpest corner.
    let turn = |i: usize| {
        let (p, v, q) = (at(i + n - 1), at(i), at(i + 1));
        (v - p).angle_to(q - v).abs()
    };
    let start = (0..n)
        .max_by(|&a, &b| turn(a).total_cmp(&turn(b)).then(b.cmp(&a)))
        .unwrap_or(0);
    let mut runs: Vec<Run> = Vec::new();
    let mut i = start;
    while i < start + n {
        let mut best = i + 1;
        let limit = (start + n).min(i + MAX_RUN);
        let mut j = i + 2;
        while j <= limit {
            if fits(ring, i, j, tol).is_some() {
                best = j;
                j += 1;
            } else {
                break;
            }
        }
        let (a, b) = (at(i), at(best));
        let chord = b - a;
        let len = chord.length();
        if len == 0.0 {
            return None;
        }
        let dir = chord / len;
        let normal = dir.perp();
        let shift = if best > i + 1 {
            fits(ring, i, best, tol).unwrap_or(0.0)
        } else {
            0.0
        };
        runs.push(Run {
            start: i,
            end: best,
            a,
            dir,
            normal,
            shift,
        });
        i = best;
    }
    if runs.iter().all(|r| r.end == r.start + 1) {
        return None;
    }
    let mut out: Ring = Vec::with_capacity(runs.len());
    for k in 0..runs.len() {
        let (r1, r2) = (&runs[(k + runs.len() - 1) % runs.len()], &runs[k]);
        let v = at(r2.start);
        out.push(corner(r1, r2, v, tol));
    }
    if out.len() < 3 || ring_signed_area2(&out).signum() != ring_signed_area2(ring).signum() {
        return None;
    }
    Some(out)
}

/// Whether every vertex strictly between `i` and `j` lies within `tol` of
/// the chord from `i` to `j` (and within its extent, up to `tol`); the
/// largest distance of one of them on the free side (left) if so.
fn fits(ring: &[DVec2], i: usize, j: usize, tol: f64) -> Option<f64> {
    let n = ring.len();
    let (a, b) = (ring[i % n], ring[j % n]);
    let chord = b - a;
    let len = chord.length();
    if len <= tol {
        return None;
    }
    let dir = chord / len;
    let mut shift: f64 = 0.0;
    for k in i + 1..j {
        let w = ring[k % n] - a;
        let along = w.dot(dir);
        let side = dir.perp_dot(w);
        if side.abs() > tol || along < -tol || along > len + tol {
            return None;
        }
        shift = shift.max(side);
    }
    Some(shift)
}

/// The corner between run `r1` (ending at vertex v) and run `r2` (starting
/// there): where their lines meet, or, when that is farther than
/// [`CORNER_REACH`] tolerances from v, the point v moved by both runs'
/// shifts. With no shift on either side it is v itself.
fn corner(r1: &Run, r2: &Run, v: DVec2, tol: f64) -> DVec2 {
    if r1.shift == 0.0 && r2.shift == 0.0 {
        return v;
    }
    let p1 = r1.a + r1.normal * r1.shift;
    let p2 = r2.a + r2.normal * r2.shift;
    let denom = r1.dir.perp_dot(r2.dir);
    if denom.abs() > 1e-9 {
        let t = (p2 - p1).perp_dot(r2.dir) / denom;
        let q = p1 + r1.dir * t;
        if q.distance(v) <= CORNER_REACH * tol {
            return q;
        }
    }
    v + r1.normal * r1.shift + r2.normal * r2.shift
}
