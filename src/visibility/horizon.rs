//! The per-sample horizon (docs/METHOD.md §6): for each azimuth bin, a lower bound
//! on the steepest sight-line slope (rise over run) blocked by the shrunk
//! occluders, valid for EVERY direction in the bin. Anything whose own
//! steepest slope is at or below the horizon over all its bins, and which
//! lies behind every chain that made the horizon, is hidden.
//!
//! Why the bound holds: a connected chain of occluder edges at height H maps
//! onto a connected arc of directions seen from the eye, so every direction
//! in that arc meets the chain. Within one bin's wedge, it meets it no
//! farther than d, the greatest distance of the chain's parts inside the
//! wedge (along a straight edge the distance is monotone between the wedge's
//! borders, so it is greatest at a border or an end point). Where it meets
//! it, solid stands up to H, so the sight line in that direction is blocked
//! up to slope (H - h) / d. Only bins that lie wholly inside a chain's arc
//! get the bound. The solver only uses chains that lie wholly nearer than
//! the object tested, so the blocking point is in front of it.
//!
//! Directions are measured by a pseudo-angle (the "diamond angle", period 4,
//! monotone in the true angle) rather than `atan2`: the argument above holds
//! for any partition of the directions into wedges, and the pseudo-angle
//! costs one division.

use glam::DVec2;

use crate::model::{Rect, squared_distance_to_segment};

/// Number of azimuth bins.
pub const BINS: usize = 2048;
/// The pseudo-angle of a full turn.
const TURN: f64 = 4.0;
const BIN_WIDTH: f64 = TURN / BINS as f64;
// A power of two, so multiplying and dividing by it is exact.
const _: () = assert!(BIN_WIDTH == 1.0 / 512.0);
const _: () = assert!(BINS.is_power_of_two() && (BINS / GROUP).is_power_of_two());
// The groups touched by one chain fit in a 64-bit mask.
const _: () = assert!(BINS / GROUP <= 64);
/// Bins per group in the coarse level that lets hidden chains be skipped.
const GROUP: usize = 32;

/// Per-bin lower bounds on the blocked slope, `-inf` where nothing is known.
#[derive(Clone, Debug)]
pub struct Horizon {
    slopes: Vec<f64>,
    chain_angles: Vec<f64>,
    /// Distance from the eye to each point of the chain being added.
    chain_dists: Vec<f64>,
    /// Per bin of the chain being added, the reciprocal of the greatest
    /// distance of its parts in the bin's wedge.
    bin_nearness: Vec<f64>,
    /// Unit direction of each bin's lower border, its x and its y.
    border_x: Vec<f64>,
    border_y: Vec<f64>,
    /// The reciprocal distances at the bin borders of the piece being
    /// added.
    border_nearness: Vec<f64>,
    /// Per group of GROUP bins, the smallest slope of its bins.
    group_min: Vec<f64>,
    /// Per bin, the tag of the chain that gave it its slope (read only
    /// where the slope is finite).
    holders: Vec<u64>,
    /// Whether a chain that cannot raise any bin is skipped before its
    /// per-bin distances are computed (always, except in tests that
    /// compare against adding every chain in full).
    pub skip_hidden: bool,
    /// The only bins that will be read (unwrapped `lo..=hi`), when the
    /// caller knows them: a chain whose arc raises none of them is not
    /// added, which leaves those bins as they would be.
    interest: Option<(i64, i64)>,
    /// The groups of GROUP bins in which some bin was raised since the
    /// last [`Horizon::clear`], one bit each: every other bin is still at
    /// minus infinity.
    touched: u64,
}

impl Default for Horizon {
    fn default() -> Self {
        let (border_x, border_y) = (0..BINS)
            .map(|b| {
                let d = direction_of(b as f64 * BIN_WIDTH);
                (d.x, d.y)
            })
            .unzip();
        Horizon {
            slopes: vec![f64::NEG_INFINITY; BINS],
            chain_angles: Vec::new(),
            chain_dists: Vec::new(),
            bin_nearness: Vec::new(),
            border_x,
            border_y,
            border_nearness: Vec::new(),
            group_min: vec![f64::NEG_INFINITY; BINS / GROUP],
            holders: vec![0; BINS],
            skip_hidden: true,
            interest: None,
            touched: 0,
        }
    }
}

/// The diamond angle of `d` in [0, 4): 0 east, 1 north, 2 west, 3 south,
/// strictly increasing counter-clockwise.
fn pseudo_angle(d: DVec2) -> f64 {
    if d.y >= 0.0 {
        if d.x >= 0.0 {
            d.y / (d.x + d.y)
        } else {
            1.0 - d.x / (d.y - d.x)
        }
    } else if d.x < 0.0 {
        2.0 - d.y / (-d.x - d.y)
    } else {
        3.0 + d.x / (d.x - d.y)
    }
}

/// The unit direction whose diamond angle is `a` (any real; period 4).
fn direction_of(a: f64) -> DVec2 {
    let a = a.rem_euclid(TURN);
    let (quadrant, t) = (a.floor(), a - a.floor());
    let d = match quadrant as u8 {
        0 => DVec2::new(1.0 - t, t),
        1 => DVec2::new(-t, 1.0 - t),
        2 => DVec2::new(t - 1.0, -t),
        _ => DVec2::new(t, t - 1.0),
    };
    d.normalize()
}

/// Pseudo-angle of `p - v` unwrapped to lie within half a turn of `reference`.
fn unwrapped_angle(v: DVec2, p: DVec2, reference: f64) -> f64 {
    let mut a = pseudo_angle(p - v);
    while a - reference > TURN / 2.0 {
        a -= TURN;
    }
    while a - reference < -TURN / 2.0 {
        a += TURN;
    }
    a
}

/// The smaller of two numbers that are not NaN (a plain comparison: the
/// same value as `f64::min`, without its NaN handling).
#[inline]
fn min_of(a: f64, b: f64) -> f64 {
    if b < a { b } else { a }
}

/// The larger of two numbers that are not NaN.
#[inline]
fn max_of(a: f64, b: f64) -> f64 {
    if b > a { b } else { a }
}

/// Fill `out` with the reciprocal distance, along the border ray of each
/// bin border from `first` on (unwrapped), to the line of a piece with
/// normal `normal` and `1 / offset` = `inverse_offset`, never below the
/// reciprocal `far` of the piece's farther end (only `far` where the ray
/// does not meet the line ahead). Written without branches, in runs of
/// borders that do not wrap, so that it compiles to packed arithmetic.
fn border_nearness(
    (xs, ys): (&[f64], &[f64]),
    first: i64,
    (normal, inverse_offset, far): (DVec2, f64, f64),
    out: &mut [f64],
) {
    let mut start = wrap(first);
    let mut out = out;
    while !out.is_empty() {
        let run = out.len().min(BINS - start);
        let (head, rest) = out.split_at_mut(run);
        for ((o, &x), &y) in head.iter_mut().zip(&xs[start..]).zip(&ys[start..]) {
            // The same arithmetic as `DVec2::dot` then the product.
            let q = (x * normal.x + y * normal.y) * inverse_offset;
            // `q.is_finite() && q > 0.0`, for a q that may be NaN.
            let ahead = q > 0.0 && q < f64::INFINITY;
            let nearer = if far > q { far } else { q };
            *o = if ahead { nearer } else { far };
        }
        out = rest;
        start = 0;
    }
}

/// The bin (unwrapped, any integer) holding pseudo-angle `a`.
fn bin_of(a: f64) -> i64 {
    floor_i64(a / BIN_WIDTH)
}

/// `x.floor() as i64` for |x| < 2^52 without a libm call (the default
/// x86-64 target has no rounding instruction).
#[inline]
pub(crate) fn floor_i64(x: f64) -> i64 {
    let t = x as i64;
    t - ((t as f64) > x) as i64
}

/// `x.ceil() as i64` for |x| < 2^52.
#[inline]
pub(crate) fn ceil_i64(x: f64) -> i64 {
    let t = x as i64;
    t + ((t as f64) < x) as i64
}

/// The groups whose bits are set in `mask` (one bit per group of GROUP
/// bins), in ascending order.
fn groups_in(mut mask: u64) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let g = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            g
        })
    })
}

fn wrap(bin: i64) -> usize {
    // BINS is a power of two: the mask is the Euclidean remainder.
    (bin & (BINS as i64 - 1)) as usize
}

impl Horizon {
    /// Back to "nothing is known", every bin of interest.
    pub fn clear(&mut self) {
        for g in groups_in(std::mem::take(&mut self.touched)) {
            self.slopes[g * GROUP..(g + 1) * GROUP].fill(f64::NEG_INFINITY);
            self.group_min[g] = f64::NEG_INFINITY;
        }
        self.interest = None;
    }

    /// Until the next [`Horizon::clear`], only the bins `bins` (as
    /// [`rect_bins`] gives them) will be read: every chain raising none of
    /// them is passed over. The range is grown by a bin on each side, far
    /// more than any rounding of the pseudo-angles, so it holds the bins of
    /// every rectangle inside the one `bins` was computed for. The rectangle
    /// tests then answer for those bins only: a rectangle "hidden" in them
    /// holds nothing (an object, a chain) that a later read of them can see.
    pub fn restrict_to_bins(&mut self, bins: (i64, i64)) {
        self.interest = Some((bins.0 - 1, bins.1 + 1));
    }

    /// Add a chain of connected occluder edges at `height`, given by its
    /// vertices in order (at least two edges, so the bins around each
    /// shared vertex are covered by some chain). Every bin wholly inside the
    /// chain's arc is raised to (height - eye) / d, where d is the greatest
    /// distance from the eye to the parts of the chain inside that bin's
    /// wedge: every ray of the bin meets the chain no farther than d.
    /// `tag` names the chain to the caller: [`Horizon::holders`] gives
    /// back the tags of the chains that hold the bins.
    pub fn add_chain(&mut self, v: DVec2, eye: f64, height: f64, tag: u64, points: &[DVec2]) {
        if height <= eye {
            return;
        }
        let n = points.len();
        if n < 2 {
            return;
        }
        self.chain_angles.clear();
        let mut reference = 0.0;
        for &p in points {
            // `d < 1e-9` for the distance d computed below (a correctly
            // rounded square root is monotone, so the square is tested
            // first and the root taken only near the threshold).
            let d2 = p.distance_squared(v);
            if d2 < 1e-16 && d2.sqrt() < 1e-9 {
                return;
            }
            reference = unwrapped_angle(v, p, reference);
            self.chain_angles.push(reference);
        }
        let lo = self
            .chain_angles
            .iter()
            .copied()
            .fold(f64::INFINITY, min_of);
        let hi = self
            .chain_angles
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, max_of);
        if hi - lo >= TURN {
            // The chain winds all the way round the eye: its arc is not an
            // interval of directions; skip it. (Each piece spans less than
            // half a turn, so the step-by-step unwrapping above follows the
            // chain's directions continuously.)
            return;
        }
        let base = bin_of(lo);
        let top = bin_of(hi);
        // Only the bins wholly inside the chain's arc are raised.
        let first_full = ceil_i64(lo / BIN_WIDTH);
        let last_full = top - 1;
        // No bin wholly inside the arc, or none that will be read: nothing
        // to raise (tested before the nearest distance is computed).
        if first_full > last_full
            || self
                .interest
                .is_some_and(|bins| !bins_overlap((first_full, last_full), bins))
        {
            return;
        }
        // With bins of interest, only those are ever read: the chain's
        // per-bin work is cut to its stretch of them (when that is one
        // stretch), which gives those bins the same slopes.
        let (first_full, last_full) = match self.interest {
            Some(bins) if self.skip_hidden => clip_to_interest((first_full, last_full), bins),
            _ => (first_full, last_full),
        };
        // The steepest slope this chain could give; if every bin it would
        // raise is already at least that steep, it adds nothing.
        let nearest = points
            .windows(2)
            .map(|w| squared_distance_to_segment(v, w[0], w[1]))
            .fold(f64::INFINITY, min_of)
            .sqrt();
        let rise = height - eye;
        // Only the bins below that slope can be raised: the others are left
        // out of the per-bin work below (they would keep their slopes).
        let (first_full, last_full) = if self.skip_hidden {
            match self.below_in(first_full, last_full, rise / nearest) {
                Some(range) => range,
                None => return,
            }
        } else {
            (first_full, last_full)
        };
        // The distances of the points, needed only by a chain that may
        // raise a bin (most are passed over above).
        self.chain_dists.clear();
        self.chain_dists
            .extend(points.iter().map(|p| p.distance(v)));
        self.bin_nearness.clear();
        self.bin_nearness
            .resize((top - base + 1) as usize, f64::INFINITY);
        for i in 0..n - 1 {
            let (a, b) = (points[i], points[i + 1]);
            let (mut ta, mut tb) = (self.chain_angles[i], self.chain_angles[i + 1]);
            let (mut da, mut db) = (self.chain_dists[i], self.chain_dists[i + 1]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
                std::mem::swap(&mut da, &mut db);
            }
            let normal = (b - a).perp();
            let offset = (a - v).dot(normal);
            let inverse_offset = 1.0 / offset;
            let far_nearness = 1.0 / da.max(db);
            // Only the bins wholly inside the chain's arc are read below.
            let ta_bin = bin_of(ta);
            let first = ta_bin.max(first_full);
            let last = bin_of(tb).min(last_full);
            if first > last {
                continue;
            }
            // The reciprocal distance at each border of the bins
            // `first..=last` (borders `first..=last + 1`), then each bin
            // takes the nearer of its two borders.
            self.border_nearness.clear();
            self.border_nearness
                .resize((last + 2 - first) as usize, 0.0);
            border_nearness(
                (&self.border_x, &self.border_y),
                first,
                (normal, inverse_offset, far_nearness),
                &mut self.border_nearness,
            );
            // The borders outside [ta, tb] are replaced by the edge's ends:
            // those at or past tb end the list, and only the first border
            // can lie at or before ta (`first` is not below ta's bin; that
            // end wins when both hold). `past_tb` is the first border at or
            // past tb: BIN_WIDTH is a power of two, so `border as f64 *
            // BIN_WIDTH` and `tb / BIN_WIDTH` are exact and `border as f64 *
            // BIN_WIDTH >= tb` is `border >= past_tb`; it is no lower than
            // tb's bin, so no lower than `first`.
            let past_tb = ceil_i64(tb / BIN_WIDTH);
            if past_tb <= last + 1 {
                let from = (past_tb - first) as usize;
                self.border_nearness[from..].fill(1.0 / db);
            }
            if first <= ta_bin {
                self.border_nearness[0] = 1.0 / da;
            }
            let slots = &mut self.bin_nearness[(first - base) as usize..=(last - base) as usize];
            let borders = &self.border_nearness;
            for ((slot, &lower), &upper) in slots.iter_mut().zip(borders).zip(&borders[1..]) {
                *slot = min_of(min_of(*slot, lower), upper);
            }
        }
        // Groups whose smallest slope may have risen: those where a bin at
        // the group's minimum was raised (the slopes only grow, so no other
        // change can move a group's minimum).
        let mut dirty: u64 = 0;
        for bin in first_full..=last_full {
            let nearness = self.bin_nearness[(bin - base) as usize];
            if nearness.is_finite() {
                let w = wrap(bin);
                let raised = rise * nearness;
                let s = &mut self.slopes[w];
                if raised > *s {
                    if *s <= self.group_min[w / GROUP] {
                        dirty |= 1 << (w / GROUP);
                    }
                    *s = raised;
                    self.holders[w] = tag;
                    self.touched |= 1 << (w / GROUP);
                }
            }
        }
        for g in groups_in(dirty) {
            let bins = &self.slopes[g * GROUP..(g + 1) * GROUP];
            // No slope is NaN, so a plain comparison is the minimum.
            self.group_min[g] = bins
                .iter()
                .fold(f64::INFINITY, |m, &x| if x < m { x } else { m });
        }
    }

    /// Append to `out` the tag of the chain holding each bin that has a
    /// slope (the last chain to raise it), in bin order; a tag holding a
    /// run of bins is appended once for the run (a chain holds bins next
    /// to each other), other repeats are left.
    pub fn holders(&self, out: &mut Vec<u64>) {
        let mut last = None;
        // Only the groups raised since the last clear hold a slope.
        for g in groups_in(self.touched) {
            let bins = g * GROUP..(g + 1) * GROUP;
            for (s, &tag) in self.slopes[bins.clone()].iter().zip(&self.holders[bins]) {
                if s.is_finite() && last != Some(tag) {
                    out.push(tag);
                    last = Some(tag);
                }
            }
        }
    }

    /// Append to `out` the tag of the chain holding each bin of `bins`
    /// (unwrapped `lo..=hi`) that has a slope.
    pub fn holders_in(&self, (lo, hi): (i64, i64), out: &mut Vec<u64>) {
        for b in lo..=hi.min(lo + BINS as i64 - 1) {
            let w = wrap(b);
            if self.slopes[w].is_finite() {
                out.push(self.holders[w]);
            }
        }
    }

    /// True when everything in `rect` up to height `top` is below the
    /// horizon seen from `(v, eye)`. Only valid for the parts of `rect` that
    /// lie behind every chain added so far.
    pub fn hides_rect(&self, v: DVec2, eye: f64, rect: &Rect, top: f64) -> bool {
        self.hides_view(&RectView::new(v, eye, rect, top))
    }

    /// [`Horizon::hides_rect`] of the rectangle `view` was made from: the
    /// same answer, bit for bit, without finding its bins and slope again.
    pub fn hides_view(&self, view: &RectView) -> bool {
        let Some((lo, hi)) = view.bins() else {
            return false;
        };
        self.read_ranges(lo, hi)
            .all(|(from, to)| self.all_at_least(from, to, view.need))
    }

    /// The sectors holding a bin that [`Horizon::hides_view`] reads for
    /// `view` and finds below the slope it needs: empty exactly when it
    /// says hidden, every sector when the view has no bins. Only chains
    /// whose arcs meet those bins can change its answer (docs/DESIGN.md,
    /// "Sweeping only where the object still shows").
    pub fn failing_sectors(&self, view: &RectView) -> Sectors {
        let Some((lo, hi)) = view.bins() else {
            return ALL_SECTORS;
        };
        self.read_ranges(lo, hi).fold(0, |failing, (from, to)| {
            failing | self.failing_in(from, to, view.need)
        })
    }

    /// The non-empty stretches of the unwrapped bins `lo..=hi` that a
    /// rectangle test reads: all of them, or with bins of interest only
    /// those (a copy of the interest a turn lower, itself, a turn higher),
    /// since nothing can be seen in the others.
    fn read_ranges(&self, lo: i64, hi: i64) -> impl Iterator<Item = (i64, i64)> {
        let n = BINS as i64;
        let ranges = match self.interest {
            Some((a, b)) if b - a + 1 < n => [-n, 0, n].map(|k| (lo.max(a + k), hi.min(b + k))),
            // The whole range, and two empty ones.
            _ => [(lo, hi), (1, 0), (1, 0)],
        };
        ranges.into_iter().filter(|(from, to)| from <= to)
    }

    /// The sectors of the bins of `lo..=hi` (unwrapped) whose slope is
    /// below `need` (or NaN): each sector's stretch of the range is asked
    /// of [`Horizon::all_at_least`].
    fn failing_in(&self, lo: i64, hi: i64, need: f64) -> Sectors {
        let width = SECTOR_BINS as i64;
        let mut failing: Sectors = 0;
        let mut from = lo;
        while from <= hi {
            let to = ((from.div_euclid(width) + 1) * width - 1).min(hi);
            if !self.all_at_least(from, to, need) {
                failing |= 1 << (wrap(from) / SECTOR_BINS);
            }
            from = to + 1;
        }
        failing
    }

    /// The first and the last bin of `lo..=hi` (unwrapped) whose slope is
    /// below `need` (or NaN), or `None` when there is none.
    fn below_in(&self, lo: i64, hi: i64, need: f64) -> Option<(i64, i64)> {
        let first = self.first_below(lo, hi, need)?;
        // `first` is below, so the backward scan stops there at the latest.
        let mut last = hi;
        while last > first && self.slopes[wrap(last)] >= need {
            last -= 1;
        }
        Some((first, last))
    }

    /// Whether every bin of `lo..=hi` (unwrapped) has a slope of at least
    /// `need`.
    fn all_at_least(&self, lo: i64, hi: i64, need: f64) -> bool {
        self.first_below(lo, hi, need).is_none()
    }

    /// The first bin of `lo..=hi` (unwrapped) whose slope is below `need`
    /// (or NaN): whole groups are passed on their minimum, the same answer
    /// as bin by bin.
    // `!(a >= b)` on purpose: a NaN fails the test, as in `all(|s| s >= need)`.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn first_below(&self, lo: i64, hi: i64, need: f64) -> Option<i64> {
        let mut b = lo;
        while b <= hi {
            let w = wrap(b);
            if w.is_multiple_of(GROUP)
                && hi - b >= GROUP as i64 - 1
                && self.group_min[w / GROUP] >= need
            {
                // The whole group is at least `need` (a group below it is
                // searched bin by bin).
                b += GROUP as i64;
                continue;
            }
            if !(self.slopes[w] >= need) {
                return Some(b);
            }
            b += 1;
        }
        None
    }
}

/// The bins (unwrapped: `lo..=hi`, `lo` in `0..BINS`) that the
/// directions from `v` to `rect` span, or `None` when `v` is (nearly) in
/// `rect`.
pub fn rect_bins(v: DVec2, rect: &Rect) -> Option<(i64, i64)> {
    nearest_and_bins(v, rect).map(|(_, bins)| bins)
}

/// The distance from `v` to the nearest point of `rect` with the bins of
/// [`rect_bins`], or `None` when `v` is (nearly) in `rect`.
fn nearest_and_bins(v: DVec2, rect: &Rect) -> Option<(f64, (i64, i64))> {
    let r_min = v.clamp(rect.min, rect.max).distance(v);
    (r_min >= 1e-6).then(|| (r_min, bins_of(v, rect)))
}

/// A rectangle up to a top height, seen from one point at eye height: the
/// bins its directions span ([`rect_bins`]) and the slope a horizon must
/// reach in each of them to hide it. Found once, it answers
/// [`Horizon::hides_view`] at every state of a sample's horizon, which is
/// what [`Horizon::hides_rect`] computes afresh each time.
#[derive(Clone, Copy, Debug, Default)]
pub struct RectView {
    /// `None` when the point is (nearly) in the rectangle: never hidden.
    /// Kept as `i32` (the bins lie in `0..2 * BINS`) so that a view is 24
    /// bytes: the solver keeps one per bucket and node of the hierarchy.
    bins: Option<(i32, i32)>,
    need: f64,
}

impl RectView {
    /// The view of something the point is (nearly) in: never hidden.
    const NEVER_HIDDEN: RectView = RectView {
        bins: None,
        need: f64::INFINITY,
    };

    /// `rect` up to `top`, seen from `v` at height `eye`.
    pub fn new(v: DVec2, eye: f64, rect: &Rect, top: f64) -> Self {
        let Some((r_min, (lo, hi))) = nearest_and_bins(v, rect) else {
            return Self::NEVER_HIDDEN;
        };
        RectView {
            bins: Some((lo as i32, hi as i32)),
            need: slope_needed((v, eye), top, r_min, &corners(rect)),
        }
    }

    /// The same view with the slope needed raised by a relative 1e-9 (plus
    /// 1e-12): a "hidden" then stays hidden under any rounding of a few ulps
    /// in the slopes compared (an incremental bake's probe,
    /// src/scale/rebake.rs).
    pub fn strictly(self) -> Self {
        RectView {
            need: self.need + self.need.abs() * 1e-9 + 1e-12,
            ..self
        }
    }

    /// An object seen from `v` at height `eye`, up to `top`, by the convex
    /// hull `hull` of its footprint (counter-clockwise, inside `rect`),
    /// with its slope taken at `r`, the distance [`object_distance`] gives,
    /// no greater than that of any point of the footprint. Its bins are
    /// the hull's when `outside_hull` (the flag [`object_distance`] gives:
    /// `v` is outside the hull by 1e-6 or more, and a convex polygon seen
    /// from outside lies between its extreme vertices' directions), the
    /// rectangle's otherwise.
    pub fn of_object(
        v: DVec2,
        eye: f64,
        (hull, rect): (&[DVec2], &Rect),
        top: f64,
        (r, outside_hull): (f64, bool),
    ) -> Self {
        let bins = if outside_hull {
            hull_bins(v, hull)
        } else {
            None
        };
        let Some((lo, hi)) = bins.or_else(|| rect_bins(v, rect)) else {
            return Self::NEVER_HIDDEN;
        };
        // The farthest point of a polygon is a vertex of its hull (of its
        // rectangle, too, which serves when there is no hull).
        let need = if hull.len() >= 3 {
            slope_needed((v, eye), top, r, hull)
        } else {
            slope_needed((v, eye), top, r, &corners(rect))
        };
        RectView {
            bins: Some((lo as i32, hi as i32)),
            need,
        }
    }

    /// The rectangle's bins, as [`rect_bins`] gives them.
    pub fn bins(&self) -> Option<(i64, i64)> {
        self.bins.map(|(lo, hi)| (i64::from(lo), i64::from(hi)))
    }

    /// The sectors of the rectangle's bins with a bin more on each side:
    /// they hold the bin of every point of the rectangle (every sector when
    /// the point is (nearly) in it).
    pub fn sectors(&self) -> Sectors {
        sectors_of_bins(self.bins())
    }
}

/// A set of sectors of directions, one bit each: the edge buckets are
/// swept by direction (docs/DESIGN.md, "Sweeping by direction").
pub type Sectors = u128;

/// Bins per sector.
pub const SECTOR_BINS: usize = 16;

/// Number of sectors: one bit of [`Sectors`] each.
pub const SECTORS: usize = BINS / SECTOR_BINS;
const _: () = assert!(SECTORS == Sectors::BITS as usize);

/// Every sector.
pub const ALL_SECTORS: Sectors = Sectors::MAX;

/// The sectors holding the bins `bins` (as [`rect_bins`] gives them) with a
/// bin more on each side (far more than any rounding of the pseudo-angles,
/// so for a rectangle's bins the mask holds the bins of every point of it);
/// every sector for `None` (the point is (nearly) in the rectangle).
fn sectors_of_bins(bins: Option<(i64, i64)>) -> Sectors {
    let Some((lo, hi)) = bins else {
        return ALL_SECTORS;
    };
    let (lo, hi) = (lo - 1, hi + 1);
    if hi - lo + 1 >= BINS as i64 {
        return ALL_SECTORS;
    }
    let width = SECTOR_BINS as i64;
    let (first, last) = (lo.div_euclid(width), hi.div_euclid(width));
    // The sectors first..=last (mod SECTORS): a run of bits, turned to
    // start at `first`.
    let count = last - first + 1;
    if count >= SECTORS as i64 {
        return ALL_SECTORS;
    }
    let run: Sectors = (1 << count) - 1;
    run.rotate_left(first.rem_euclid(SECTORS as i64) as u32)
}

/// The slope a horizon must reach, seen from `v` at height `eye`, to hide
/// something up to `top` whose nearest point is `near` away: taken at
/// `near` when the top is at or above the eye, else at the farthest of
/// `far` (points among which lies its farthest point).
fn slope_needed((v, eye): (DVec2, f64), top: f64, near: f64, far: &[DVec2]) -> f64 {
    if top >= eye {
        (top - eye) / near
    } else {
        let r_max = far.iter().map(|c| c.distance(v)).fold(0.0, max_of);
        (top - eye) / r_max
    }
}

/// The bins `lo..=hi` (`lo` in `0..BINS`) that the directions from `v`
/// (not in `rect`) to `rect` span.
fn bins_of(v: DVec2, rect: &Rect) -> (i64, i64) {
    let corners = corners(rect);
    let reference = unwrapped_angle(v, corners[0], 0.0);
    let (mut lo, mut hi) = (reference, reference);
    for c in &corners[1..] {
        let a = unwrapped_angle(v, *c, reference);
        lo = lo.min(a);
        hi = hi.max(a);
    }
    bins_between(lo, hi)
}

/// The bins holding the unwrapped pseudo-angles `lo..=hi`, shifted by
/// whole turns so that the first lies in `0..BINS`.
fn bins_between(lo: f64, hi: f64) -> (i64, i64) {
    let (lo, hi) = (bin_of(lo), bin_of(hi));
    let shift = lo.div_euclid(BINS as i64) * BINS as i64;
    (lo - shift, hi - shift)
}

/// The distance from `v` to the nearest point of an object whose
/// footprint has the convex hull `hull` (counter-clockwise) and the
/// bounding rectangle `rect`: the hull's distance when `v` lies outside
/// it by 1e-6 or more (rounding cannot then put `v` on the wrong side of
/// an edge), the rectangle's otherwise. Either is no greater than the
/// distance to any point of the footprint. The flag says which: true for
/// the hull's.
pub fn object_distance(v: DVec2, hull: &[DVec2], rect: &Rect) -> (f64, bool) {
    let n = hull.len();
    let mut outside = false;
    let mut d2 = f64::INFINITY;
    for i in 0..n {
        let (a, b) = (hull[i], hull[(i + 1) % n]);
        outside |= (b - a).perp_dot(v - a) < 0.0;
        d2 = min_of(d2, squared_distance_to_segment(v, a, b));
    }
    let d = d2.sqrt();
    if n >= 3 && outside && d >= 1e-6 {
        (d, true)
    } else {
        (v.clamp(rect.min, rect.max).distance(v), false)
    }
}

/// The bins the directions from `v` to the convex polygon `hull` span, for
/// `v` outside it by 1e-6 or more (as [`object_distance`] finds it), or
/// `None` should they span half a turn or more. The vertices'
/// pseudo-angles are unwrapped one after the other round the polygon (no
/// edge subtends nearly half a turn from that far); a convex polygon seen
/// from outside lies between its extreme vertices' directions.
fn hull_bins(v: DVec2, hull: &[DVec2]) -> Option<(i64, i64)> {
    let (&first, rest) = hull.split_first()?;
    let mut reference = unwrapped_angle(v, first, 0.0);
    let (mut lo, mut hi) = (reference, reference);
    for &p in rest {
        reference = unwrapped_angle(v, p, reference);
        lo = min_of(lo, reference);
        hi = max_of(hi, reference);
    }
    (hi - lo < TURN / 2.0).then(|| bins_between(lo, hi))
}

/// The corners of `rect`, counter-clockwise from its minimum.
fn corners(rect: &Rect) -> [DVec2; 4] {
    [
        rect.min,
        DVec2::new(rect.max.x, rect.min.y),
        rect.max,
        DVec2::new(rect.min.x, rect.max.y),
    ]
}

/// Which directions a set of rectangles covers, seen from a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cover {
    /// There is no rectangle.
    Nothing,
    /// The shortest range of bins (as [`rect_bins`] gives them) that holds
    /// the bins of every rectangle.
    Bins(i64, i64),
    /// No range short of a turn holds them all (or the point is in one).
    Everything,
}

/// The directions from `v` that the rectangles `rects` cover.
pub fn covering_bins<'r>(v: DVec2, rects: impl Iterator<Item = &'r Rect>) -> Cover {
    covering_of(rects.map(|rect| rect_bins(v, rect)))
}

/// The directions that ranges of bins cover, each as [`rect_bins`] gives
/// it (`None` for a rectangle the point is in): [`covering_bins`] of
/// rectangles whose bins are already known.
pub fn covering_of(ranges: impl Iterator<Item = Option<(i64, i64)>>) -> Cover {
    let n = BINS as i64;
    let mut covered = BinMask::default();
    let mut any = false;
    for range in ranges {
        let Some((lo, hi)) = range else {
            return Cover::Everything;
        };
        if hi - lo + 1 >= n {
            return Cover::Everything;
        }
        any = true;
        covered.insert(lo, hi);
    }
    if !any {
        return Cover::Nothing;
    }
    // The longest run of uncovered bins, going round once from a covered
    // bin; the range is the rest of the turn.
    let start = covered.first().expect("a bin is covered") as i64;
    let (mut best, mut best_end, mut run) = (0i64, start, 0i64);
    for k in 1..=n {
        if covered.contains(start + k) {
            if run > best {
                best = run;
                best_end = start + k;
            }
            run = 0;
        } else {
            run += 1;
        }
    }
    if best == 0 {
        return Cover::Everything;
    }
    // Bins best_end .. best_end + (n - best) - 1 hold every covered bin.
    let lo = best_end.rem_euclid(n);
    Cover::Bins(lo, lo + n - best - 1)
}

/// A set of bins modulo a turn, one bit each: the union of ranges of
/// bins, asked whether a range meets it as [`bins_overlap`] would ask of
/// each range in turn.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BinMask([u64; BINS / 64]);

impl Default for BinMask {
    fn default() -> Self {
        BinMask([0; BINS / 64])
    }
}

impl BinMask {
    /// Adds the bins `lo..=hi` (unwrapped: any integers; a range of a turn
    /// or more adds every bin).
    pub fn insert(&mut self, lo: i64, hi: i64) {
        Self::for_each_word(lo, hi, |w, bits| self.0[w] |= bits);
    }

    /// Whether some bin of `lo..=hi` (unwrapped; a range of a turn or more
    /// holds every bin) is in the set.
    pub fn meets(&self, lo: i64, hi: i64) -> bool {
        let mut met = false;
        Self::for_each_word(lo, hi, |w, bits| met |= self.0[w] & bits != 0);
        met
    }

    /// Whether bin `b` (unwrapped) is in the set.
    pub fn contains(&self, b: i64) -> bool {
        let w = wrap(b);
        self.0[w / 64] >> (w % 64) & 1 != 0
    }

    /// The lowest bin in the set (in `0..BINS`), if any.
    pub fn first(&self) -> Option<usize> {
        self.0
            .iter()
            .position(|&w| w != 0)
            .map(|i| i * 64 + self.0[i].trailing_zeros() as usize)
    }

    /// Calls `f(word, bits)` for the words and bits of the bins `lo..=hi`
    /// taken modulo a turn (nothing when `hi < lo`).
    fn for_each_word(lo: i64, hi: i64, mut f: impl FnMut(usize, u64)) {
        if hi < lo {
            return;
        }
        let n = BINS;
        let len = (hi - lo + 1).min(n as i64) as usize;
        let start = wrap(lo);
        let mut bits = |a: usize, b: usize| {
            // Bins a..b, within 0..=n.
            let mut k = a;
            while k < b {
                let w = k / 64;
                let end = b.min((w + 1) * 64);
                let count = end - k;
                let run = if count == 64 {
                    u64::MAX
                } else {
                    ((1u64 << count) - 1) << (k % 64)
                };
                f(w, run);
                k = end;
            }
        };
        if start + len <= n {
            bits(start, start + len);
        } else {
            bits(start, n);
            bits(0, start + len - n);
        }
    }
}

/// The bins of the unwrapped range `lo..=hi` (under a turn wide) that lie
/// in some copy of `interest` shifted by whole turns, when they form one
/// stretch; the whole range otherwise (an interest of a turn or more, or
/// two stretches).
fn clip_to_interest((lo, hi): (i64, i64), (a, b): (i64, i64)) -> (i64, i64) {
    let n = BINS as i64;
    if b - a + 1 >= n || hi - lo + 1 > n {
        return (lo, hi);
    }
    // The copy starting at or before `lo` and the next one are the only
    // copies that can meet the range: the one before ends before `lo`, and
    // the one after next starts past `hi`.
    let k = (lo - a).div_euclid(n) * n;
    let pieces = [0, n].map(|j| (lo.max(a + k + j), hi.min(b + k + j)));
    match pieces.map(|(x, y)| x <= y) {
        [true, false] => pieces[0],
        [false, true] => pieces[1],
        _ => (lo, hi),
    }
}

/// Whether two ranges of bins (`lo..=hi`, unwrapped: any integers) share a
/// bin modulo a turn.
pub fn bins_overlap(a: (i64, i64), b: (i64, i64)) -> bool {
    let n = BINS as i64;
    if a.1 - a.0 + 1 >= n || b.1 - b.0 + 1 >= n {
        return true;
    }
    // Both shifted by whole turns to start in 0..n (a chain's unwrapped
    // bins may lie a turn or more from a rectangle's), so they meet modulo
    // a turn exactly when they meet shifted by -n, 0 or n.
    let start = |r: (i64, i64)| {
        let lo = r.0.rem_euclid(n);
        (lo, lo + r.1 - r.0)
    };
    let (a, b) = (start(a), start(b));
    [-n, 0, n].iter().any(|&k| b.0 + k <= a.1 && a.0 <= b.1 + k)
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// The border distances filled run by run (across the wrap of the
        /// bins too) are, border by border, the reciprocal distance along
        /// that border's ray to the piece's line where the ray meets it
        /// ahead, never below the far end's, and the far end's elsewhere.
        #[test]
        fn the_border_distances_are_those_of_each_border_ray(
            first in -3 * BINS as i64..3 * BINS as i64,
            len in 1usize..BINS,
            angle in 0.0f64..std::f64::consts::TAU,
            offset in -500.0f64..500.0,
            far in 0.0001f64..1.0,
        ) {
            let horizon = Horizon::default();
            let normal = DVec2::from_angle(angle);
            let mut out = vec![0.0; len];
            border_nearness(
                (&horizon.border_x, &horizon.border_y),
                first,
                (normal, 1.0 / offset, far),
                &mut out,
            );
            for (k, &got) in out.iter().enumerate() {
                let dir = direction_of((first + k as i64) as f64 * BIN_WIDTH);
                let q = dir.dot(normal) / offset;
                let want = if q.is_finite() && q > 0.0 { q.max(far) } else { far };
                proptest::prop_assert!(
                    (got - want).abs() <= 1e-12 * want,
                    "border {}: {} against {}", first + k as i64, got, want
                );
            }
        }

        /// The sectors of a rectangle hold the sector of the bin of every
        /// point in it, seen from anywhere outside it (corners, edges and
        /// inside points alike), and only sectors its directions reach.
        #[test]
        fn a_rectangle_s_sectors_hold_the_bin_of_each_of_its_points(
            vx in -300.0f64..300.0, vy in -300.0f64..300.0,
            x in -200.0f64..200.0, y in -200.0f64..200.0,
            w in 0.0f64..80.0, h in 0.0f64..80.0,
            tx in 0.0f64..=1.0, ty in 0.0f64..=1.0,
        ) {
            let v = DVec2::new(vx, vy);
            let rect = Rect { min: DVec2::new(x, y), max: DVec2::new(x + w, y + h) };
            let mask = RectView::new(v, 0.0, &rect, 1.0).sectors();
            let sector_of = |p: DVec2| {
                let bin = wrap(bin_of(pseudo_angle(p - v)));
                (1 as Sectors) << (bin / SECTOR_BINS)
            };
            let inside = v.clamp(rect.min, rect.max).distance(v) < 1e-6;
            for p in [
                rect.min,
                rect.max,
                DVec2::new(rect.min.x, rect.max.y),
                DVec2::new(rect.max.x, rect.min.y),
                rect.min + (rect.max - rect.min) * DVec2::new(tx, ty),
                DVec2::new(rect.min.x + w * tx, rect.max.y),
                DVec2::new(rect.max.x, rect.min.y + h * ty),
            ] {
                if p.distance(v) > 1e-9 {
                    proptest::prop_assert!(mask & sector_of(p) != 0, "{p:?} from {v:?}");
                }
            }
            if inside {
                proptest::prop_assert_eq!(mask, ALL_SECTORS);
            } else if let Some((lo, hi)) = rect_bins(v, &rect) {
                // No more than the bins' sectors and one bin either side.
                let width = SECTOR_BINS as i64;
                let sectors = ((hi + 1).div_euclid(width) - (lo - 1).div_euclid(width) + 1)
                    .min(SECTORS as i64);
                proptest::prop_assert_eq!(mask.count_ones() as i64, sectors);
            }
        }

        /// An object's view by its footprint's hull holds the bin of every
        /// point of the footprint, and its distance is no greater than any
        /// of theirs, seen from anywhere (outside the hull, in the notch of
        /// an L, inside the footprint); the hull's bins are never wider than
        /// the rectangle's.
        #[test]
        fn an_object_s_view_holds_every_point_of_its_footprint(
            vx in -120.0f64..120.0, vy in -120.0f64..120.0,
            x in -60.0f64..60.0, y in -60.0f64..60.0,
            w in 1.0f64..40.0, d in 1.0f64..40.0,
            arm in 0.1f64..0.9, turn in 0.0f64..std::f64::consts::TAU,
            tx in 0.0f64..=1.0, ty in 0.0f64..=1.0,
        ) {
            use crate::model::{Building, Polygon};
            // An L of w x d with its arm cut at `arm`, turned by `turn`.
            let (sin, cos) = turn.sin_cos();
            let at = |a: f64, b: f64| DVec2::new(x + a * cos - b * sin, y + a * sin + b * cos);
            let local = [(0.0, 0.0), (w, 0.0), (w, d * arm), (w * arm, d * arm), (w * arm, d), (0.0, d)];
            let ring: Vec<DVec2> = local.iter().map(|&(a, b)| at(a, b)).collect();
            let building = Building {
                id: "l".into(),
                footprint: vec![Polygon { exterior: ring.clone(), holes: Vec::new() }],
                height: 10.0,
                occludes: true,
            };
            let hull = crate::visibility::index::footprint_hull(&building);
            let mut rect = Rect::EMPTY;
            for p in &ring {
                rect.include(*p);
            }
            let v = DVec2::new(vx, vy);
            let (r, outside) = object_distance(v, &hull, &rect);
            let view = RectView::of_object(v, 0.0, (&hull, &rect), 1.0, (r, outside));
            let mut points = ring.clone();
            for i in 0..ring.len() {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                points.push(a + (b - a) * tx);
            }
            // Points inside the L: in the full-width strip and in the arm.
            points.push(at(w * tx, d * arm * ty));
            points.push(at(w * arm * tx, d * ty));
            for p in points {
                let dist = p.distance(v);
                proptest::prop_assert!(r <= dist + 1e-9, "{p:?} at {dist} nearer than {r}");
                if dist > 1e-9 {
                    let Some((lo, hi)) = view.bins() else { continue };
                    let bin = bin_of(pseudo_angle(p - v));
                    let held = (lo..=hi).contains(&bin)
                        || (lo..=hi).contains(&(bin + BINS as i64))
                        || (lo..=hi).contains(&(bin - BINS as i64));
                    proptest::prop_assert!(held, "{p:?} (bin {bin}) outside {lo}..={hi} from {v:?}");
                }
            }
            if let (Some((lo, hi)), Some((rlo, rhi))) = (view.bins(), rect_bins(v, &rect)) {
                proptest::prop_assert!(hi - lo <= rhi - rlo);
            }
        }
    }

    #[test]
    fn bin_ranges_meet_modulo_a_turn_however_far_they_are_unwrapped() {
        let n = BINS as i64;
        // A chain unwrapped below zero against a range reaching past a turn.
        assert!(bins_overlap((-1150, -1100), (1760, 3509)));
        assert!(!bins_overlap(
            (-1150 + 2 * n, -1100 + 2 * n),
            (1760, 1760 + 200)
        ));
        assert!(bins_overlap((5 - 3 * n, 9 - 3 * n), (9, 12)));
        assert!(!bins_overlap((5 - 3 * n, 9 - 3 * n), (10, 12)));
        assert!(bins_overlap((n - 2, n + 3), (0, 0)));
    }

    #[test]
    fn the_covering_range_holds_every_rectangle_and_skips_the_largest_gap() {
        let at = |x: f64, y: f64| Rect {
            min: DVec2::new(x - 1.0, y - 1.0),
            max: DVec2::new(x + 1.0, y + 1.0),
        };
        let v = DVec2::ZERO;
        // East and north: a quarter turn, not the three quarters round.
        let rects = [at(50.0, 0.0), at(0.0, 50.0)];
        let Cover::Bins(lo, hi) = covering_bins(v, rects.iter()) else {
            panic!("a quarter turn is covered")
        };
        for r in &rects {
            let (a, b) = rect_bins(v, r).unwrap();
            assert!(bins_overlap((a, b), (lo, hi)));
            // Every bin of it is in the range, modulo a turn.
            let n = BINS as i64;
            for bin in a..=b {
                let shifted = lo + (bin - lo).rem_euclid(n);
                assert!(shifted <= hi, "bin {bin} outside {lo}..{hi}");
            }
        }
        assert!(hi - lo < BINS as i64 / 4 + 40, "{lo}..{hi}");
        // Four directions a quarter apart still leave a gap.
        let four = [at(50.0, 0.0), at(0.0, 50.0), at(-50.0, 0.0), at(0.0, -50.0)];
        assert!(matches!(covering_bins(v, four.iter()), Cover::Bins(..)));
        assert_eq!(covering_bins(v, [].iter()), Cover::Nothing);
        assert_eq!(covering_bins(v, [at(0.5, 0.0)].iter()), Cover::Everything);
    }

    proptest::proptest! {
        /// A union of ranges meets a range exactly when one of the ranges
        /// overlaps it ([`bins_overlap`]), and holds exactly their bins;
        /// the covering range holds every bin of every range and leaves out
        /// the longest run of bins none of them holds.
        #[test]
        fn a_union_of_ranges_answers_as_its_ranges_do(
            ranges in proptest::collection::vec((-3 * BINS as i64..3 * BINS as i64, 0i64..2 * BINS as i64), 0..6),
            probe in (-3 * BINS as i64..3 * BINS as i64, 0i64..2 * BINS as i64),
        ) {
            let n = BINS as i64;
            let ranges: Vec<(i64, i64)> = ranges.iter().map(|&(lo, len)| (lo, lo + len % (n + 8))).collect();
            let mut union = BinMask::default();
            for &(lo, hi) in &ranges {
                union.insert(lo, hi);
            }
            let probe = (probe.0, probe.0 + probe.1 % (n + 8));
            let overlaps = ranges.iter().any(|&r| bins_overlap(r, probe));
            proptest::prop_assert_eq!(union.meets(probe.0, probe.1), overlaps);
            for b in 0..n {
                let held = ranges.iter().any(|&r| bins_overlap(r, (b, b)));
                proptest::prop_assert_eq!(union.contains(b), held);
                proptest::prop_assert_eq!(union.contains(b + n), held);
            }
            match covering_of(ranges.iter().map(|&r| Some(r))) {
                Cover::Nothing => proptest::prop_assert!(ranges.is_empty()),
                Cover::Everything => {
                    // A whole turn, or no bin left out by every range.
                    let full = ranges.iter().any(|&(lo, hi)| hi - lo + 1 >= n);
                    proptest::prop_assert!(full || (0..n).all(|b| union.contains(b)));
                }
                Cover::Bins(lo, hi) => {
                    proptest::prop_assert!((0..n).contains(&lo) && hi >= lo && hi - lo < n);
                    // Every held bin lies in the range, modulo a turn.
                    for b in 0..n {
                        if union.contains(b) {
                            proptest::prop_assert!(bins_overlap((b, b), (lo, hi)));
                        }
                    }
                    // No run of free bins is longer than the one left out.
                    let left_out = n - (hi - lo + 1);
                    let mut run = 0;
                    for b in 0..2 * n {
                        run = if union.contains(b) { 0 } else { run + 1 };
                        proptest::prop_assert!(run <= left_out);
                    }
                }
            }
        }
    }

    proptest::proptest! {
        /// A chain's range cut to the bins of interest keeps every bin of
        /// the range that some copy of the interest holds, and adds none.
        #[test]
        fn a_range_cut_to_the_interest_keeps_every_bin_of_interest(
            lo in -5000i64..5000, width in 0i64..2048,
            a in -5000i64..5000, interest_width in 0i64..2100,
        ) {
            let n = BINS as i64;
            let (hi, b) = (lo + width, a + interest_width);
            let (x, y) = clip_to_interest((lo, hi), (a, b));
            proptest::prop_assert!(lo <= x && y <= hi && x <= y);
            for bin in lo..=hi {
                let of_interest = (bin - a).rem_euclid(n) <= b - a;
                proptest::prop_assert!(!of_interest || (x <= bin && bin <= y), "bin {bin}");
            }
        }
    }

    proptest::proptest! {
        /// The failing sectors are empty exactly when the rectangle is
        /// hidden, and hold the sector of every bin the test reads and
        /// finds too low, with or without bins of interest.
        #[test]
        fn the_failing_sectors_hold_every_bin_below_the_slope_needed(
            walls in proptest::collection::vec(
                (-120.0f64..120.0, -120.0f64..120.0, -60.0f64..60.0, -60.0f64..60.0, 3.0f64..30.0),
                0..8,
            ),
            x in -150.0f64..150.0, y in -150.0f64..150.0,
            w in 0.5f64..60.0, h in 0.5f64..60.0, top in 0.0f64..40.0,
            interest in proptest::option::of((0i64..2048, 0i64..600)),
        ) {
            let v = DVec2::ZERO;
            let mut horizon = Horizon::default();
            if let Some((lo, width)) = interest {
                horizon.restrict_to_bins((lo, lo + width));
            }
            for (i, &(ax, ay, dx, dy, height)) in walls.iter().enumerate() {
                let a = DVec2::new(ax, ay);
                let points = [a, a + DVec2::new(dx, dy) * 0.5, a + DVec2::new(dx, dy)];
                horizon.add_chain(v, 2.0, height, i as u64, &points);
            }
            let rect = Rect { min: DVec2::new(x, y), max: DVec2::new(x + w, y + h) };
            let view = RectView::new(v, 2.0, &rect, top);
            let failing = horizon.failing_sectors(&view);
            proptest::prop_assert_eq!(failing == 0, horizon.hides_view(&view));
            let Some((lo, hi)) = view.bins() else {
                proptest::prop_assert_eq!(failing, ALL_SECTORS);
                return Ok(());
            };
            for b in lo..=hi {
                let read = match horizon.interest {
                    Some((a, c)) => [-2048i64, 0, 2048].iter().any(|&k| a + k <= b && b <= c + k),
                    None => true,
                };
                let w = wrap(b);
                // Below the slope needed, or NaN.
                let below = matches!(
                    horizon.slopes[w].partial_cmp(&view.need),
                    Some(std::cmp::Ordering::Less) | None
                );
                if read && below {
                    let sector = (1 as Sectors) << (w / SECTOR_BINS);
                    proptest::prop_assert!(failing & sector != 0, "bin {b}");
                }
            }
        }
    }

    proptest::proptest! {
        /// Passing over the chains that cannot raise a bin, and leaving out
        /// of a chain's per-bin work the bins at either end of its arc that
        /// are already as steep as it could make them, gives the horizon
        /// that adding every chain in full gives: the same slopes, bit for
        /// bit, held by the same chains; with bins of interest, the same
        /// slopes in those bins.
        #[test]
        fn skipping_what_cannot_rise_leaves_the_full_horizon(
            chains in proptest::collection::vec(
                (
                    (-300.0f64..300.0, -300.0f64..300.0),
                    proptest::collection::vec((-40.0f64..40.0, -40.0f64..40.0), 1..6),
                    2.0f64..40.0,
                ),
                1..40,
            ),
            interest in (0i64..2048, 0i64..600),
        ) {
            let v = DVec2::new(0.5, -0.25);
            let mut skipping = Horizon::default();
            let mut full = Horizon {
                skip_hidden: false,
                ..Horizon::default()
            };
            // With bins of interest, those bins as without.
            let mut restricted = Horizon::default();
            restricted.restrict_to_bins((interest.0, interest.0 + interest.1));
            for (tag, ((x, y), steps, height)) in chains.iter().enumerate() {
                let mut p = DVec2::new(*x, *y);
                let mut points = vec![p];
                for (dx, dy) in steps {
                    p += DVec2::new(*dx, *dy);
                    points.push(p);
                }
                skipping.add_chain(v, 1.7, *height, tag as u64, &points);
                full.add_chain(v, 1.7, *height, tag as u64, &points);
                restricted.add_chain(v, 1.7, *height, tag as u64, &points);
            }
            let (a, c) = restricted.interest.unwrap();
            for b in 0..BINS {
                proptest::prop_assert_eq!(skipping.slopes[b].to_bits(), full.slopes[b].to_bits());
                if skipping.slopes[b].is_finite() {
                    proptest::prop_assert_eq!(skipping.holders[b], full.holders[b]);
                }
                if (b as i64 - a).rem_euclid(BINS as i64) <= c - a {
                    proptest::prop_assert_eq!(restricted.slopes[b].to_bits(), full.slopes[b].to_bits(), "bin {}", b);
                }
            }
        }
    }

    #[test]
    fn a_long_wall_hides_a_lower_house_behind_it_but_not_a_tower() {
        let mut h = Horizon::default();
        // Wall 10 m high along x = 10 from y = -50 to 50, in short edges.
        let pts = (0..=100).map(|i| DVec2::new(10.0, -50.0 + i as f64));
        let pts: Vec<DVec2> = pts.collect();
        for i in 0..pts.len() - 2 {
            h.add_chain(DVec2::ZERO, 2.0, 10.0, i as u64, &pts[i..i + 3]);
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
