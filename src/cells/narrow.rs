//! Free space where a viewer fits: the free space opened by a polygon "disc"
//! of diameter `min_gap` (erode, then dilate), kept a small clearance away
//! from every footprint, and then cleaned of outline features shorter than
//! a fraction of `min_gap` by cuts that only ever remove free space.
//!
//! Owns the structuring polygon, the Minkowski erosion and dilation by it,
//! and the conservative outline clean-up. Occluders are not touched here.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use geo::BooleanOps;
use geo::bool_ops::FillRule;
use glam::DVec2;

use crate::geometry::convert::{multipolygon_from_geo, multipolygon_to_geo};
use crate::geometry::memo::{MemoKey, ShapeMemo};
use crate::model::{MultiPolygon, Polygon, Ring, cut_points, piece_count, ring_signed_area2};

/// Distance in metres that the kept free space stays away from every
/// footprint (and from the region's outline) on top of the opening. It
/// absorbs the boolean operation's snapping (about 1e-5 m for a city ten
/// kilometres across) so that no cell can touch a footprint.
pub const CLEARANCE: f64 = 1e-3;

/// Sides of the structuring polygon: a regular polygon circumscribed about
/// the disc of radius min_gap / 2 (so it contains that disc). Its width is
/// between min_gap and min_gap / cos(pi / 16), 2% more.
pub const SIDES: usize = 16;

/// Outline edges shorter than this fraction of min_gap are cut away.
pub const SHORT_EDGE: f64 = 0.4;

/// Corners of the free space at least this sharp (interior angle, degrees)
/// are kept sharp by the clean-up; sharper ones stay cut off.
pub const MIN_CORNER_DEG: f64 = 80.0;

/// Pieces of kept free space smaller than this (square metres) are
/// dropped; every real piece holds a whole structuring polygon (at least
/// 0.78 min_gap^2).
const MIN_PIECE_AREA: f64 = 1e-4;

/// The kept free space.
pub struct Opened {
    /// Free space where a viewer fits, in the model's conventions.
    pub free: MultiPolygon,
}

/// The free space opened by the structuring polygon of width `min_gap`,
/// then cleaned up, tile by tile (see [`super::tiles`]), then with its
/// facade runs straightened (see `super::straighten`). `min_gap <= 0`
/// returns `free` unchanged.
/// Tiles whose opened free space `memo` holds are taken from it.
pub fn open_free_space(free: &MultiPolygon, min_gap: f64, memo: &ShapeMemo) -> Opened {
    open_free_space_with(free, min_gap, &super::tiles::Tiling::new(min_gap), memo)
}

/// [`open_free_space`] with a given tiling (tests compare tilings).
pub fn open_free_space_with(
    free: &MultiPolygon,
    min_gap: f64,
    tiling: &super::tiles::Tiling,
    memo: &ShapeMemo,
) -> Opened {
    if min_gap.is_nan() || min_gap <= 0.0 || free.is_empty() {
        return Opened { free: free.clone() };
    }
    let stitched = super::tiles::open_tiled(
        free,
        tiling,
        memo,
        || MemoKey::new("open tile").number(min_gap),
        |piece| open_piece(piece, min_gap),
    );
    // The border of two tiles may leave short edges where their clean-ups
    // differed: one more clean-up pass over the merged outline.
    let cleaned = clean(&stitched, free, min_gap);
    let straight = super::straighten::straighten(&cleaned, min_gap);
    Opened { free: straight }
}

/// The opening and clean-up of one piece of free space, whole.
pub fn open_piece(free: &MultiPolygon, min_gap: f64) -> MultiPolygon {
    let r = 0.5 * min_gap;
    // Erode by D(r + s) = D(r) + D(s), dilate by D(r): the result is the
    // union of the translates of D(r) whose D(s)-neighbourhood lies in free.
    let eroded = erode_by_polygon(free, r + CLEARANCE, 1.0 + 1e-12);
    if eroded.0.is_empty() {
        return Vec::new();
    }
    let opened = dilate_by_polygon(&eroded, r, 1.0 - 1e-12);
    drop(eroded);
    let opened = multipolygon_from_geo(&opened, MIN_PIECE_AREA);
    clean(&opened, free, min_gap)
}

/// The outline clean-up of the opened free space `opened`; `free` is the
/// free space it was opened from (what added corners must keep clear of).
fn clean(opened: &MultiPolygon, free: &MultiPolygon, min_gap: f64) -> MultiPolygon {
    let short = SHORT_EDGE * min_gap;
    let short_starts = short_edge_starts(opened.iter().flat_map(rings_of), short);
    if short_starts.is_empty() {
        return opened.clone();
    }
    let walls = Walls::new(free, BUCKET * short, &short_starts);
    opened
        .iter()
        .filter_map(|p| clean_polygon(p, short, &walls))
        .filter(|p| 0.5 * ring_signed_area2(&p.exterior) >= MIN_PIECE_AREA)
        .collect()
}

/// The vertices of the regular polygon with `SIDES` sides whose inscribed
/// circle has radius `apothem` (sides facing the directions k * 2 pi / SIDES),
/// scaled by `scale` (just above or below 1 to push rounding the safe way).
fn structuring_polygon(apothem: f64, scale: f64) -> Vec<DVec2> {
    let circum = apothem / (PI / SIDES as f64).cos() * scale;
    (0..SIDES)
        .map(|k| DVec2::from_angle((2 * k + 1) as f64 * PI / SIDES as f64) * circum)
        .collect()
}

/// The convex hull of the segment a-b swept by the convex polygon `d`
/// (counter-clockwise vertices around the origin), as a `geo` polygon.
fn swept(a: DVec2, b: DVec2, d: &[DVec2]) -> geo::Polygon<f64> {
    let mut points: Vec<DVec2> = d
        .iter()
        .map(|&v| a + v)
        .chain(d.iter().map(|&v| b + v))
        .collect();
    let hull = convex_hull(&mut points);
    geo::Polygon::new(
        hull.iter().map(|p| geo::Coord { x: p.x, y: p.y }).collect(),
        Vec::new(),
    )
}

/// Andrew's monotone chain: the convex hull, counter-clockwise.
fn convex_hull(points: &mut [DVec2]) -> Vec<DVec2> {
    points.sort_by(|p, q| p.x.total_cmp(&q.x).then(p.y.total_cmp(&q.y)));
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && (hull[hull.len() - 1] - hull[hull.len() - 2]).perp_dot(p - hull[hull.len() - 1])
                    <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

fn all_edges(mp: &MultiPolygon) -> impl Iterator<Item = (DVec2, DVec2)> + '_ {
    mp.iter()
        .flat_map(|p| std::iter::once(&p.exterior).chain(p.holes.iter()))
        .flat_map(|ring| (0..ring.len()).map(move |i| (ring[i], ring[(i + 1) % ring.len()])))
}

/// `free` minus every edge swept by D(apothem): the points p of `free` with
/// p + D inside `free`. (If p + D leaves `free` it meets the outline at some
/// q on an edge e, and then p lies in q - D = q + D, inside e swept by D.)
fn erode_by_polygon(free: &MultiPolygon, apothem: f64, scale: f64) -> geo::MultiPolygon<f64> {
    let d = structuring_polygon(apothem, scale);
    let cuts: Vec<geo::Polygon<f64>> = all_edges(free).map(|(a, b)| swept(a, b, &d)).collect();
    multipolygon_to_geo(free)
        .difference_with_fill_rule(&geo::MultiPolygon::new(cuts), FillRule::NonZero)
}

/// `area` plus every edge of it swept by D(apothem): the Minkowski sum
/// with D (a point within D of the area is inside it or within D of its
/// outline).
fn dilate_by_polygon(
    area: &geo::MultiPolygon<f64>,
    apothem: f64,
    scale: f64,
) -> geo::MultiPolygon<f64> {
    let d = structuring_polygon(apothem, scale);
    let model = multipolygon_from_geo(area, 0.0);
    let sweeps: Vec<geo::Polygon<f64>> = all_edges(&model).map(|(a, b)| swept(a, b, &d)).collect();
    multipolygon_to_geo(&model)
        .union_with_fill_rule(&geo::MultiPolygon::new(sweeps), FillRule::NonZero)
}

// ---------------------------------------------------------------------------
// Outline clean-up.

/// Ring vertices as a doubly linked list (free space on the left of every
/// edge: exterior counter-clockwise, holes clockwise).
struct Outline {
    points: Vec<DVec2>,
    next: Vec<usize>,
    prev: Vec<usize>,
    alive: Vec<bool>,
    /// Live vertices per ring (a ring keeps at least 3).
    ring_of: Vec<usize>,
    ring_len: Vec<usize>,
    grid: Grid,
}

/// A uniform bucket grid of segments (by an index), kept only over the
/// active buckets: those near the short edges, where the clean-up works.
pub(super) struct Grid {
    size: f64,
    active: HashSet<(i64, i64), KeyHasher>,
    /// The blocks of 2^COARSE_SHIFT x 2^COARSE_SHIFT buckets holding an
    /// active bucket: most segments lie far from every short edge, and one
    /// or two lookups here tell so.
    coarse: HashSet<(i64, i64), KeyHasher>,
    /// Per bucket with something filed under it, the last entry filed
    /// there in `filed`.
    buckets: HashMap<(i64, i64), usize, KeyHasher>,
    /// Every (segment, bucket) filing as a list per bucket: the segment and
    /// the bucket's entry filed before it ([`NO_ENTRY`] for the first). One
    /// flat list instead of a list per bucket, so that a city's grid is two
    /// allocations, not one per bucket.
    filed: Vec<(usize, usize)>,
    /// The keys of the segment being filed (kept to save an allocation).
    scratch: Vec<(i64, i64)>,
}

/// The end of a bucket's list of entries in [`Grid`].
const NO_ENTRY: usize = usize::MAX;

/// Buckets per side of a [`Grid`]'s coarse block, as a power of two.
const COARSE_SHIFT: u32 = 4;

/// A segment whose bucket range spans more coarse blocks than this is
/// filed step by step without the coarse test first.
const COARSE_TEST_MAX: i64 = 16;

/// The grid's key hasher: foldhash, seeded afresh in each run as the
/// standard one is (so keys cannot be picked ahead to collide), but several
/// times faster on these small keys than the standard keyed SipHash. The
/// grid is never iterated, so no output depends on the seed.
type KeyHasher = foldhash::fast::RandomState;

impl Grid {
    /// A grid of buckets `size` wide, active within two buckets of `around`.
    pub(super) fn new(size: f64, around: impl Iterator<Item = DVec2>) -> Grid {
        let mut grid = Grid {
            size,
            active: HashSet::default(),
            coarse: HashSet::default(),
            buckets: HashMap::default(),
            filed: Vec::new(),
            scratch: Vec::new(),
        };
        let mut last = None;
        for p in around {
            let (kx, ky) = grid.key(p);
            // Points come along lines, often several to a bucket: a bucket
            // repeated from the point before adds nothing.
            if last.replace((kx, ky)) == Some((kx, ky)) {
                continue;
            }
            for dx in -2..=2 {
                for dy in -2..=2 {
                    grid.active.insert((kx + dx, ky + dy));
                }
            }
            // The coarse blocks of those 5 x 5 buckets (one to four),
            // inserted as found: a set collected from the active buckets
            // would reserve room for all of them.
            for cx in (kx - 2) >> COARSE_SHIFT..=(kx + 2) >> COARSE_SHIFT {
                for cy in (ky - 2) >> COARSE_SHIFT..=(ky + 2) >> COARSE_SHIFT {
                    grid.coarse.insert((cx, cy));
                }
            }
        }
        grid
    }

    fn key(&self, p: DVec2) -> (i64, i64) {
        (
            (p.x / self.size).floor() as i64,
            (p.y / self.size).floor() as i64,
        )
    }

    /// File segment `i` (a -> b) under every active bucket it may pass
    /// through: the buckets of points every half bucket along it, with their
    /// neighbours. A segment within 0.75 * size of a point p is then filed
    /// under p's bucket.
    pub(super) fn insert(&mut self, i: usize, a: DVec2, b: DVec2) {
        if self.active.is_empty() || !self.may_file(a, b) {
            return;
        }
        let steps = piece_count(a, b, 0.5 * self.size);
        let mut keys = std::mem::take(&mut self.scratch);
        keys.clear();
        let mut last = None;
        for p in cut_points(a, b, steps) {
            let (kx, ky) = self.key(p);
            // Steps are half a bucket apart: a bucket repeated from the
            // step before adds nothing.
            if last.replace((kx, ky)) == Some((kx, ky)) {
                continue;
            }
            for dx in -1..=1 {
                for dy in -1..=1 {
                    if self.active.contains(&(kx + dx, ky + dy)) {
                        keys.push((kx + dx, ky + dy));
                    }
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        for &k in &keys {
            let last = self.buckets.entry(k).or_insert(NO_ENTRY);
            self.filed.push((i, *last));
            *last = self.filed.len() - 1;
        }
        self.scratch = keys;
    }

    /// Whether [`Grid::insert`] may file the segment a -> b anywhere: false
    /// only when no coarse block around its buckets holds an active one.
    /// Its steps lie between its ends, so their buckets lie within the
    /// ends' bucket range grown by one (for rounding) and the buckets it is
    /// filed under within that range grown by one more.
    fn may_file(&self, a: DVec2, b: DVec2) -> bool {
        let (ka, kb) = (self.key(a), self.key(b));
        let lo = |u: i64, v: i64| u.min(v).saturating_sub(2) >> COARSE_SHIFT;
        let hi = |u: i64, v: i64| u.max(v).saturating_add(2) >> COARSE_SHIFT;
        let (x0, x1, y0, y1) = (
            lo(ka.0, kb.0),
            hi(ka.0, kb.0),
            lo(ka.1, kb.1),
            hi(ka.1, kb.1),
        );
        if (x1 - x0 + 1).saturating_mul(y1 - y0 + 1) > COARSE_TEST_MAX {
            return true;
        }
        (x0..=x1).any(|x| (y0..=y1).any(|y| self.coarse.contains(&(x, y))))
    }

    /// Segments filed near `p` (some may be stale), or `None` when p is
    /// outside the active buckets (nothing is known there).
    pub(super) fn near(&self, p: DVec2) -> Option<Vec<usize>> {
        let k = self.key(p);
        if !self.active.contains(&k) {
            return None;
        }
        let mut v: Vec<usize> = Vec::new();
        let mut entry = self.buckets.get(&k).copied().unwrap_or(NO_ENTRY);
        while entry != NO_ENTRY {
            let (segment, before) = self.filed[entry];
            v.push(segment);
            entry = before;
        }
        v.sort_unstable();
        v.dedup();
        Some(v)
    }
}

/// The original free space's outline (footprints and region) near the
/// short edges: what added free space must keep clear of.
struct Walls {
    segments: Vec<(DVec2, DVec2)>,
    grid: Grid,
}

impl Walls {
    fn new(free: &MultiPolygon, size: f64, around: &[DVec2]) -> Walls {
        let segments: Vec<(DVec2, DVec2)> = all_edges(free).collect();
        let mut grid = Grid::new(size, around.iter().copied());
        for (i, &(a, b)) in segments.iter().enumerate() {
            grid.insert(i, a, b);
        }
        Walls { segments, grid }
    }

    /// Whether every wall stays at least `gap` from the segments and no wall
    /// vertex lies inside the polygon `area`; everything looked at lies
    /// within 0.75 of a bucket of `near`.
    fn clear_of(&self, area: &[DVec2], segments: &[(DVec2, DVec2)], gap: f64, near: DVec2) -> bool {
        let Some(found) = self.grid.near(near) else {
            return false;
        };
        for i in found {
            let (a, b) = self.segments[i];
            if segments
                .iter()
                .any(|&(p, q)| segment_distance(p, q, a, b) < gap)
            {
                return false;
            }
            if crate::model::point_in_ring(a, area) {
                return false;
            }
        }
        true
    }
}

/// The distance between the closed segments p-q and a-b.
fn segment_distance(p: DVec2, q: DVec2, a: DVec2, b: DVec2) -> f64 {
    use crate::model::distance_to_segment;
    if segments_meet(p, q, a, b) {
        return 0.0;
    }
    distance_to_segment(p, a, b)
        .min(distance_to_segment(q, a, b))
        .min(distance_to_segment(a, p, q))
        .min(distance_to_segment(b, p, q))
}

pub(super) fn orient(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// Whether the closed segments p-q and r-s share a point, with a tolerance
/// that counts near-touching as touching.
pub(super) fn segments_meet(p: DVec2, q: DVec2, r: DVec2, s: DVec2) -> bool {
    let scale = (q - p).length() * (s - r).length();
    let tol = 1e-12 * scale.max(1e-300);
    let d1 = orient(p, q, r);
    let d2 = orient(p, q, s);
    let d3 = orient(r, s, p);
    let d4 = orient(r, s, q);
    let straddle = |x: f64, y: f64| (x <= tol && y >= -tol) || (x >= -tol && y <= tol);
    if !(straddle(d1, d2) && straddle(d3, d4)) {
        return false;
    }
    // Collinear-ish: need overlapping extents.
    let lo = |u: f64, v: f64| u.min(v);
    let hi = |u: f64, v: f64| u.max(v);
    lo(p.x, q.x) <= hi(r.x, s.x) + tol.sqrt()
        && lo(r.x, s.x) <= hi(p.x, q.x) + tol.sqrt()
        && lo(p.y, q.y) <= hi(r.y, s.y) + tol.sqrt()
        && lo(r.y, s.y) <= hi(p.y, q.y) + tol.sqrt()
}

/// Whether `p` lies in the closed triangle a, b, c (either orientation),
/// with a small tolerance outwards.
fn in_triangle(p: DVec2, a: DVec2, b: DVec2, c: DVec2) -> bool {
    let area = orient(a, b, c);
    let tol = 1e-9 * area.abs().max(1e-300);
    let (d1, d2, d3) = (orient(a, b, p), orient(b, c, p), orient(c, a, p));
    if area >= 0.0 {
        d1 >= -tol && d2 >= -tol && d3 >= -tol
    } else {
        d1 <= tol && d2 <= tol && d3 <= tol
    }
}

impl Outline {
    fn new(polygon: &Polygon, cell: f64, around: &[DVec2]) -> Outline {
        let mut out = Outline {
            points: Vec::new(),
            next: Vec::new(),
            prev: Vec::new(),
            alive: Vec::new(),
            ring_of: Vec::new(),
            ring_len: Vec::new(),
            grid: Grid::new(cell, around.iter().copied()),
        };
        for (r, ring) in std::iter::once(&polygon.exterior)
            .chain(polygon.holes.iter())
            .enumerate()
        {
            let start = out.points.len();
            let n = ring.len();
            for (k, &p) in ring.iter().enumerate() {
                out.points.push(p);
                out.next.push(start + (k + 1) % n);
                out.prev.push(start + (k + n - 1) % n);
                out.alive.push(true);
                out.ring_of.push(r);
            }
            out.ring_len.push(n);
        }
        for i in 0..out.points.len() {
            let j = out.next[i];
            out.grid.insert(i, out.points[i], out.points[j]);
        }
        out
    }

    fn len(&self, i: usize) -> f64 {
        self.points[i].distance(self.points[self.next[i]])
    }

    /// Turn at vertex i: > 0 left (convex for the free space on the left).
    fn turn(&self, i: usize) -> f64 {
        let (p, v, n) = (
            self.points[self.prev[i]],
            self.points[i],
            self.points[self.next[i]],
        );
        (v - p).perp_dot(n - v)
    }

    /// Whether a change that removes the triangle `tri` (bounded by the old
    /// chain and the new segments) is safe: no live vertex other than
    /// `own` inside the closed triangle, and no live edge other than those
    /// starting at `skip` meets a new segment. Everything looked at lies
    /// within 4.5 * short of `near` (0.75 of a bucket), so the bucket of
    /// `near` holds all of it.
    fn clear(
        &self,
        tri: [DVec2; 3],
        segments: &[(DVec2, DVec2)],
        skip: &[usize],
        own: &[usize],
        near: DVec2,
    ) -> bool {
        let Some(seen) = self.grid.near(near) else {
            return false;
        };
        for e in seen {
            if !self.alive[e] || !self.alive[self.next[e]] {
                continue;
            }
            let (a, b) = (self.points[e], self.points[self.next[e]]);
            if !skip.contains(&e) && segments.iter().any(|&(p, q)| segments_meet(p, q, a, b)) {
                return false;
            }
            if !own.contains(&e) && in_triangle(a, tri[0], tri[1], tri[2]) {
                return false;
            }
        }
        true
    }

    fn link(&mut self, a: usize, b: usize) {
        self.next[a] = b;
        self.prev[b] = a;
        let (p, q) = (self.points[a], self.points[b]);
        self.grid.insert(a, p, q);
    }

    fn remove(&mut self, v: usize) {
        self.alive[v] = false;
        self.ring_len[self.ring_of[v]] -= 1;
    }

    /// Try to get rid of the short edge starting at `a`: edges up to
    /// 2 * short between two left turns (the rounded corners of the
    /// opening) are first tried for [`Outline::meet_neighbours`] adding
    /// the corner back; edges under `short` are then cut away. Returns the
    /// vertices whose outgoing edges changed.
    fn fix(&mut self, a: usize, short: f64, walls: &Walls) -> Option<Vec<usize>> {
        if !self.alive[a] || self.len(a) >= 2.0 * short || self.ring_len[self.ring_of[a]] <= 3 {
            return None;
        }
        let b = self.next[a];
        let (ca, cb) = (self.turn(a) > 0.0, self.turn(b) > 0.0);
        if ca
            && cb
            && let Some(changed) = self.meet_neighbours(a, short, false, Some(walls))
        {
            return Some(changed);
        }
        if self.len(a) >= short {
            return None;
        }
        for (convex, v) in [(ca, a), (cb, b)] {
            if convex && let Some(changed) = self.cut_convex(v, short) {
                return Some(changed);
            }
        }
        self.meet_neighbours(a, short, true, None)
    }

    /// Remove the convex vertex v whose outgoing or incoming edge is short:
    /// the neighbour across the long side is replaced by a point on that
    /// side at most 2 * short from v (or the neighbour itself when the side
    /// is short), and v is joined straight to the other neighbour. The
    /// removed triangle lies on the free side, so free space only shrinks.
    fn cut_convex(&mut self, v: usize, short: f64) -> Option<Vec<usize>> {
        let (p, n) = (self.prev[v], self.next[v]);
        let (pv, vv, nv) = (self.points[p], self.points[v], self.points[n]);
        let lp = pv.distance(vv);
        let ln = nv.distance(vv);
        // Which side is the short one: the other gets the new point.
        let (long_end, long_len, on_prev) = if lp >= ln {
            (pv, lp, true)
        } else {
            (nv, ln, false)
        };
        let reach = 2.0 * short;
        let cut_point = if long_len < reach + short {
            None
        } else {
            Some(vv + (long_end - vv) * (reach / long_len))
        };
        let c = cut_point.unwrap_or(long_end);
        let (tri, seg) = if on_prev {
            ([c, vv, nv], (c, nv))
        } else {
            ([pv, vv, c], (pv, c))
        };
        // Edges touching the new segment's ends, and the triangle's corners.
        let skip = [self.prev[p], p, v, n];
        if orient(tri[0], tri[1], tri[2]).abs() < 1e-18
            || !self.clear(tri, &[seg], &skip, &[p, v, n], vv)
        {
            return None;
        }
        let ring = self.ring_of[v];
        self.remove(v);
        match cut_point {
            None => {
                self.link(p, n);
                Some(vec![p])
            }
            Some(c) => {
                let k = self.add_point(c, ring);
                self.link(p, k);
                self.link(k, n);
                Some(vec![p, k])
            }
        }
    }

    fn add_point(&mut self, c: DVec2, ring: usize) -> usize {
        let k = self.points.len();
        self.points.push(c);
        self.alive.push(true);
        self.ring_of.push(ring);
        self.ring_len[ring] += 1;
        self.next.push(k);
        self.prev.push(k);
        k
    }

    /// Replace the short edge a -> b by the point q where the lines of the
    /// neighbouring edges meet (beyond a and beyond b), if q is within
    /// 4 * short of both.
    ///
    /// `cut`: q is on the free side (both ends turn right, reflex): the
    /// triangle a, q, b is cut away from the free space.
    ///
    /// Otherwise q is outside (both ends turn left, as along the rounded
    /// corners the opening leaves): the triangle a, q, b is added, which
    /// keeps corners sharp, but only if the corner at q is at least
    /// [`MIN_CORNER_DEG`] and `walls` (the original outline) stays at least
    /// half the clearance away from it.
    fn meet_neighbours(
        &mut self,
        a: usize,
        short: f64,
        cut: bool,
        walls: Option<&Walls>,
    ) -> Option<Vec<usize>> {
        let b = self.next[a];
        let (pa, nb) = (self.prev[a], self.next[b]);
        if pa == b || nb == a || pa == nb {
            return None;
        }
        let (ppa, pav, pbv, pnb) = (
            self.points[pa],
            self.points[a],
            self.points[b],
            self.points[nb],
        );
        let d1 = pav - ppa;
        let d2 = pbv - pnb;
        let denom = d1.perp_dot(-d2);
        if denom.abs() < 1e-12 * d1.length() * d2.length() {
            return None;
        }
        // pav + t d1 = pbv + u d2.
        let w = pbv - pav;
        let t = w.perp_dot(-d2) / denom;
        let u = d1.perp_dot(w) / denom;
        if !(t >= 0.0 && u >= 0.0) {
            return None;
        }
        let q = pav + d1 * t;
        if q.distance(pav) > 4.0 * short || q.distance(pbv) > 4.0 * short {
            return None;
        }
        let side = orient(pav, pbv, q);
        if cut && side <= 0.0 || !cut && side >= 0.0 {
            return None;
        }
        let tri = [pav, q, pbv];
        let segments = [(pav, q), (q, pbv)];
        if !self.clear(tri, &segments, &[pa, a, b], &[pa, a, b, nb], pav) {
            return None;
        }
        if !cut {
            // The corner at q: the turn from d1 to -d2 must leave at least
            // MIN_CORNER_DEG inside.
            let turn = d1.angle_to(-d2).abs().to_degrees();
            let walls = walls?;
            if 180.0 - turn < MIN_CORNER_DEG
                || !walls.clear_of(&tri, &segments, 0.5 * CLEARANCE, pav)
            {
                return None;
            }
        }
        let ring = self.ring_of[a];
        self.remove(a);
        self.remove(b);
        let k = self.add_point(q, ring);
        self.link(pa, k);
        self.link(k, nb);
        Some(vec![pa, k])
    }

    /// The live rings, each from its lowest live vertex.
    fn rings(&self) -> Vec<Ring> {
        let mut done = vec![false; self.points.len()];
        let mut rings: Vec<(usize, Ring)> = Vec::new();
        for s in 0..self.points.len() {
            if !self.alive[s] || done[s] {
                continue;
            }
            let mut ring = Vec::new();
            let mut i = s;
            loop {
                done[i] = true;
                ring.push(self.points[i]);
                i = self.next[i];
                if i == s || done[i] {
                    break;
                }
            }
            rings.push((self.ring_of[s], ring));
        }
        rings.sort_by_key(|(r, _)| *r);
        rings.into_iter().map(|(_, ring)| ring).collect()
    }
}

/// The start of every edge of `rings` shorter than `2 short`.
fn short_edge_starts<'a>(rings: impl Iterator<Item = &'a Ring>, short: f64) -> Vec<DVec2> {
    rings
        .flat_map(|ring| {
            (0..ring.len())
                .filter(move |&i| ring[i].distance(ring[(i + 1) % ring.len()]) < 2.0 * short)
                .map(move |i| ring[i])
        })
        .collect()
}

/// Rid the polygon's outline of edges shorter than `short` (see
/// [`Outline::fix`]), never changing its topology: a change is refused if
/// any other part of the outline comes into it. `None` if it vanished.
fn clean_polygon(polygon: &Polygon, short: f64, walls: &Walls) -> Option<Polygon> {
    let short_starts = short_edge_starts(rings_of(polygon), short);
    if short_starts.is_empty() {
        return Some(polygon.clone());
    }
    let mut outline = Outline::new(polygon, BUCKET * short, &short_starts);
    let mut work: Vec<usize> = (0..outline.points.len())
        .filter(|&i| outline.len(i) < 2.0 * short)
        .collect();
    // In the order of the edges' start points, so that the same outline
    // is cleaned the same way whichever vertex its rings start at (a tile
    // sees the same place as the whole city).
    work.sort_by(|&a, &b| {
        let (p, q) = (outline.points[a], outline.points[b]);
        q.x.total_cmp(&p.x).then(q.y.total_cmp(&p.y))
    });
    let mut guard = 8 * outline.points.len() + 100;
    while let Some(i) = work.pop() {
        guard -= 1;
        if guard == 0 {
            break;
        }
        if let Some(changed) = outline.fix(i, short, walls) {
            for c in changed {
                for v in [outline.prev[c], c, outline.next[c]] {
                    if outline.alive[v] && outline.len(v) < 2.0 * short {
                        work.push(v);
                    }
                }
            }
        }
    }
    let mut rings = outline.rings().into_iter();
    let exterior = rings.next()?;
    if ring_signed_area2(&exterior) <= 0.0 {
        return None;
    }
    let holes: Vec<Ring> = rings
        .filter(|h| h.len() >= 3 && ring_signed_area2(h) < 0.0)
        .collect();
    Some(Polygon { exterior, holes })
}

/// Bucket size of the clean-up's grids, in units of the short-edge length.
const BUCKET: f64 = 6.0;

fn rings_of(p: &Polygon) -> impl Iterator<Item = &Ring> {
    std::iter::once(&p.exterior).chain(p.holes.iter())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square() {
        let mut pts = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
            DVec2::new(0.5, 0.5),
        ];
        let h = convex_hull(&mut pts);
        assert_eq!(h.len(), 4);
        assert!(ring_signed_area2(&h) > 0.0);
    }

    proptest::proptest! {
        /// The grid's contract: a point in a bucket within two buckets of
        /// an `around` point gets every segment within 0.75 buckets of it,
        /// each once, in ascending order, and only segments filed; a point
        /// elsewhere gets `None`. Random segments, filed in an order that
        /// revisits buckets.
        #[test]
        fn a_grid_finds_every_segment_near_an_active_point(
            around in proptest::collection::vec((-40.0f64..40.0, -40.0f64..40.0), 1..12),
            segments in proptest::collection::vec(
                ((-50.0f64..50.0, -50.0f64..50.0), (-12.0f64..12.0, -12.0f64..12.0)),
                0..40,
            ),
            probes in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 1..40),
            size in 1.0f64..6.0,
        ) {
            let v = |(x, y): (f64, f64)| DVec2::new(x, y);
            let around: Vec<DVec2> = around.into_iter().map(v).collect();
            let segments: Vec<(DVec2, DVec2)> =
                segments.into_iter().map(|(a, d)| (v(a), v(a) + v(d))).collect();
            let mut grid = Grid::new(size, around.iter().copied());
            for (i, &(a, b)) in segments.iter().enumerate() {
                grid.insert(i, a, b);
            }
            let bucket = |p: DVec2| ((p.x / size).floor() as i64, (p.y / size).floor() as i64);
            for p in probes.into_iter().map(v) {
                let k = bucket(p);
                let active = around.iter().any(|&q| {
                    let c = bucket(q);
                    (c.0 - k.0).abs() <= 2 && (c.1 - k.1).abs() <= 2
                });
                match grid.near(p) {
                    None => proptest::prop_assert!(!active),
                    Some(found) => {
                        proptest::prop_assert!(active);
                        proptest::prop_assert!(found.windows(2).all(|w| w[0] < w[1]));
                        proptest::prop_assert!(found.iter().all(|&i| i < segments.len()));
                        for (i, &(a, b)) in segments.iter().enumerate() {
                            if crate::model::distance_to_segment(p, a, b) <= 0.75 * size {
                                proptest::prop_assert!(found.contains(&i), "segment {}", i);
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn structuring_polygon_contains_its_disc() {
        let d = structuring_polygon(0.25, 1.0);
        for i in 0..SIDES {
            let (a, b) = (d[i], d[(i + 1) % SIDES]);
            let mid = 0.5 * (a + b);
            assert!((mid.length() - 0.25).abs() < 1e-12);
        }
    }
}
