//! Straightened facade runs of the kept free space (docs/geometry.md
//! section 4, "Straight facades"): a run of outline vertices that all lie
//! within [`TOLERANCE`] x min_gap of one line becomes one straight edge on
//! the free side of all of them, so that the junctions of wall-sharing
//! buildings (facades off by a few centimetres) stop putting vertices, and
//! so small cells, into the free space. Only free space is removed: a run
//! is straightened only if the part it cuts away holds no other piece of
//! the outline.
//!
//! Owns the choice of runs, their lines, the checks and the new outline.

use glam::DVec2;

use super::narrow::{Grid, orient, segments_meet};
use crate::model::{
    MultiPolygon, Polygon, Ring, cut_points, piece_count, point_in_ring, ring_signed_area2,
};

/// Vertices within this fraction of min_gap of a line (6 cm by default) are
/// straightened to it: more than the largest facade offset of neighbours
/// in map data seen from a chord (a 5 cm step is 2.5 cm either side of it),
/// and far below min_gap / 2, the least distance from a wall of a viewer's
/// centre.
pub const TOLERANCE: f64 = 0.12;

/// A run's corner point may lie at most this many tolerances from the
/// vertex it replaces; farther (nearly parallel runs) the corner is put
/// off the vertex by both runs' shifts instead.
const CORNER_REACH: f64 = 2.0;

/// Longest run, in vertices.
const MAX_RUN: usize = 512;

/// Rounds of checks: a run refused turns back into its own edges, which
/// changes its neighbours' corners, which are then checked again.
const ROUNDS: usize = 8;

/// The free space with every facade run straightened; nothing changes when
/// `min_gap <= 0`.
pub fn straighten(free: &MultiPolygon, min_gap: f64) -> MultiPolygon {
    if min_gap.is_nan() || min_gap <= 0.0 || free.is_empty() {
        return free.clone();
    }
    let tol = TOLERANCE * min_gap;
    let rings: Vec<&Ring> = free
        .iter()
        .flat_map(|p| std::iter::once(&p.exterior).chain(p.holes.iter()))
        .collect();
    let mut plans: Vec<Option<Plan>> = rings.iter().map(|r| Plan::new(r, tol)).collect();
    if plans.iter().all(Option::is_none) {
        return free.clone();
    }
    // The outline's segments, filed near the runs that change.
    // Buckets of at least 4 m: few enough to hold for a whole city, and
    // more than 4 times the widest part a run cuts away (4 t).
    let size = (16.0 * tol).max(4.0);
    let step = 0.5 * size;
    let mut around: Vec<DVec2> = Vec::new();
    for (ring, plan) in rings.iter().zip(&plans) {
        let Some(plan) = plan else { continue };
        for run in plan
            .runs
            .iter()
            .filter(|r| r.end > r.start + 1 || r.shift > 0.0)
        {
            let (a, b) = (ring[run.start % ring.len()], ring[run.end % ring.len()]);
            samples(a, b, step, &mut around);
        }
    }
    let mut ids: Vec<(u32, u32)> = Vec::new();
    let mut grid = Grid::new(size, around.into_iter());
    for (ri, ring) in rings.iter().enumerate() {
        for i in 0..ring.len() {
            grid.insert(ids.len(), ring[i], ring[(i + 1) % ring.len()]);
            ids.push((ri as u32, i as u32));
        }
    }
    for (ri, plan) in plans.iter_mut().enumerate() {
        let Some(p) = plan else { continue };
        let mut ok = false;
        for _ in 0..ROUNDS {
            let corners = p.corners(rings[ri], tol);
            let refused: Vec<usize> = (0..p.runs.len())
                .filter(|&k| {
                    !p.runs[k].kept && !p.check(k, &corners, &rings, ri, &grid, &ids, step)
                })
                .collect();
            for &k in &refused {
                p.runs[k].kept = true;
            }
            if refused.is_empty() {
                p.done = Some(corners);
                ok = true;
                break;
            }
        }
        if !ok {
            *plan = None;
        }
    }
    let mut k = 0;
    let mut next = |ring: &Ring| {
        let plan = &plans[k];
        k += 1;
        match plan.as_ref().and_then(|p| p.ring()) {
            Some(r) => r,
            None => ring.clone(),
        }
    };
    free.iter()
        .map(|p| Polygon {
            exterior: next(&p.exterior),
            holes: p.holes.iter().map(&mut next).collect(),
        })
        .collect()
}

/// Points from a to b at most `step` apart, both ends included.
fn samples(a: DVec2, b: DVec2, step: f64, out: &mut Vec<DVec2>) {
    out.extend(cut_points(a, b, piece_count(a, b, step)));
}

/// A run of the ring from vertex `start` to vertex `end` (indices modulo
/// the ring's length, `end > start`): the line through the chord shifted to
/// the free side (left) by `shift`.
#[derive(Clone)]
struct Run {
    start: usize,
    end: usize,
    a: DVec2,
    dir: DVec2,
    normal: DVec2,
    shift: f64,
    /// Refused: the run's own edges stay.
    kept: bool,
}

impl Run {
    fn new(ring: &[DVec2], start: usize, end: usize, shift: f64) -> Run {
        let n = ring.len();
        let (a, b) = (ring[start % n], ring[end % n]);
        let dir = (b - a).normalize_or_zero();
        Run {
            start,
            end,
            a,
            dir,
            normal: dir.perp(),
            shift,
            kept: false,
        }
    }
}

struct Plan {
    runs: Vec<Run>,
    /// The corners once every run passed its checks.
    done: Option<Vec<DVec2>>,
}

impl Plan {
    /// The runs of the ring, greedily from its sharpest corner; `None` when
    /// no run has more than one edge.
    fn new(ring: &[DVec2], tol: f64) -> Option<Plan> {
        let n = ring.len();
        if n < 4 {
            return None;
        }
        let at = |i: usize| ring[i % n];
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
            let mut best = (i + 1, 0.0);
            let limit = (start + n).min(i + MAX_RUN);
            let mut j = i + 2;
            while j <= limit {
                match fits(ring, i, j, tol) {
                    Some(shift) => best = (j, shift),
                    None => break,
                }
                j += 1;
            }
            if at(i) == at(best.0) {
                return None;
            }
            runs.push(Run::new(ring, i, best.0, best.1));
            i = best.0;
        }
        if runs.iter().all(|r| r.end == r.start + 1) {
            return None;
        }
        Some(Plan { runs, done: None })
    }

    /// The runs as they stand: a kept run is its own edges, unshifted.
    fn live(&self, ring: &[DVec2]) -> Vec<Run> {
        let mut out = Vec::with_capacity(self.runs.len());
        for r in &self.runs {
            if r.kept {
                out.extend((r.start..r.end).map(|i| Run::new(ring, i, i + 1, 0.0)));
            } else {
                out.push(r.clone());
            }
        }
        out
    }

    /// The corner at the start of every live run, in order (a kept run
    /// counts as its own edges).
    fn corners(&self, ring: &[DVec2], tol: f64) -> Vec<DVec2> {
        let live = self.live(ring);
        let n = ring.len();
        let m = live.len();
        (0..m)
            .map(|k| {
                corner(
                    &live[(k + m - 1) % m],
                    &live[k],
                    ring[live[k].start % n],
                    tol,
                )
            })
            .collect()
    }

    /// Index into `corners` of the corner at ring vertex `v` (a live run
    /// start).
    fn corner_at(&self, v: usize) -> usize {
        let mut k = 0;
        for r in &self.runs {
            if r.start == v {
                return k;
            }
            k += if r.kept { r.end - r.start } else { 1 };
        }
        k
    }

    /// Whether run `k` (not kept) may be straightened with these corners:
    /// the corners lie on the free side of their vertices, the new edge
    /// runs forward, and the part cut away (between the run's edges and the
    /// new edge) holds no vertex and meets no edge of the outline other
    /// than the run's own and its two neighbours.
    #[allow(clippy::too_many_arguments)]
    fn check(
        &self,
        k: usize,
        corners: &[DVec2],
        rings: &[&Ring],
        ri: usize,
        grid: &Grid,
        ids: &[(u32, u32)],
        step: f64,
    ) -> bool {
        let ring = rings[ri];
        let n = ring.len();
        let run = &self.runs[k];
        let m = corners.len();
        let c0 = self.corner_at(run.start);
        let (q0, q1) = (corners[c0], corners[(c0 + 1) % m]);
        let (s, e) = (run.start % n, run.end % n);
        if q0 == ring[s] && q1 == ring[e] && run.end == run.start + 1 {
            return true;
        }
        if (q1 - q0).dot(run.dir) <= 0.0 {
            return false;
        }
        if !free_side(ring, s, q0) || !free_side(ring, e, q1) {
            return false;
        }
        let mut cut: Vec<DVec2> = vec![q0];
        cut.extend((run.start..=run.end).map(|i| ring[i % n]));
        cut.push(q1);
        if ring_signed_area2(&cut) < 0.0 {
            return false;
        }
        let mut segments = vec![(q0, q1)];
        if q0 != ring[s] {
            segments.push((ring[s], q0));
        }
        if q1 != ring[e] {
            segments.push((ring[e], q1));
        }
        let own = |r: u32, i: u32| {
            if r as usize != ri {
                return false;
            }
            let i = i as usize;
            // The run's edges and its two neighbours.
            let rel = (i + n - (run.start + n - 1) % n) % n;
            rel <= run.end - run.start + 1
        };
        // The neighbours' far ends stay out of the part cut away.
        let (before, after) = (ring[(run.start + n - 1) % n], ring[(run.end + 1) % n]);
        if point_in_ring(before, &cut) || point_in_ring(after, &cut) {
            return false;
        }
        let mut near: Vec<usize> = Vec::new();
        let mut points = Vec::new();
        samples(q0, q1, step, &mut points);
        for p in points {
            match grid.near(p) {
                Some(v) => near.extend(v),
                None => return false,
            }
        }
        near.sort_unstable();
        near.dedup();
        for id in near {
            let (r, i) = ids[id];
            let other = rings[r as usize];
            let (a, b) = (other[i as usize], other[(i as usize + 1) % other.len()]);
            if own(r, i) {
                continue;
            }
            if segments.iter().any(|&(p, q)| segments_meet(p, q, a, b)) || point_in_ring(a, &cut) {
                return false;
            }
        }
        true
    }

    /// The new ring, once every run passed.
    fn ring(&self) -> Option<Ring> {
        let out = self.done.clone()?;
        if out.len() < 3 {
            return None;
        }
        Some(out)
    }
}

/// Whether `q` lies on the free (left) side of the ring at vertex `v`.
fn free_side(ring: &[DVec2], v: usize, q: DVec2) -> bool {
    let n = ring.len();
    let (p, c, x) = (ring[(v + n - 1) % n], ring[v], ring[(v + 1) % n]);
    if q == c {
        return true;
    }
    let (l1, l2) = (orient(p, c, q) >= 0.0, orient(c, x, q) >= 0.0);
    if orient(p, c, x) >= 0.0 {
        l1 && l2
    } else {
        l1 || l2
    }
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
