//! The per-sample visibility solver: for one sample V, find every object
//! that the shrunk occluders do not hide from V (docs/METHOD.md §5 and §6).
//!
//! Near V, a cull map (a window of the global pixel grid) decides objects
//! pixel by pixel. Everything else is decided by a horizon that grows with
//! distance: objects and pyramid nodes are visited nearest first, and before
//! one at distance r is tested, every occluder chain whose farthest vertex is
//! nearer than r is added to the horizon. A chain nearer than all of an
//! object's points stands in front of it on every ray that meets both, so
//! the test is valid without any window; whole districts behind a street
//! wall are rejected with one test of their pyramid node.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec2;

use super::bitset::ObjectSet;
use super::cullmap::CullWindow;
use super::horizon::{
    ALL_SECTORS, Horizon, RectView, SECTORS, Sectors, bins_overlap, floor_i64, rect_bins,
};
use super::index::{
    MAX_CHAIN_PIECES, MAX_EDGE_PIECE, NO_PARENT, NODE_LEVELS, NODE_SHIFTS, SceneIndex,
};
use crate::model::{Rect, distance_to_segment};

/// Default half-size in metres of the near-field cull map.
pub const DEFAULT_NEAR_FIELD: f64 = 48.0;

/// Chains fed to the horizon start at every `stride`-th piece of a ring and
/// hold `stride + 1` pieces, so consecutive chains share a piece and the bins
/// around every vertex lie inside some chain's arc. Far away a longer chain
/// costs little in tightness (its pieces are a small angle) and saves the
/// per-chain work; the stride is 1 near the eye and grows with distance.
fn chain_stride(distance: f64) -> u32 {
    match distance {
        d if d < 96.0 => 1,
        d if d < 192.0 => 2,
        _ => MAX_STRIDE,
    }
}

/// The greatest stride [`chain_stride`] gives.
const MAX_STRIDE: u32 = 4;

/// The most pieces a chain holds: the greatest stride plus one.
const MAX_PIECES: u32 = MAX_STRIDE + 1;

// Every chain fits in one stretch of the index's ring points.
const _: () = assert!(MAX_PIECES as usize <= MAX_CHAIN_PIECES);

/// Side in metres of the absolute squares (anchored at local (0, 0)) that
/// decide a chain's stride: the chains starting at an edge depend only on
/// the edge, its ring and the sample, never on the index's bucket grid.
const STRIDE_CELL: f64 = 16.0;

/// The stride square holding `p`.
fn stride_cell(p: DVec2) -> (i64, i64) {
    (floor_i64(p.x / STRIDE_CELL), floor_i64(p.y / STRIDE_CELL))
}

/// The stride of a chain starting at `a`, seen from a sample in stride
/// square `vc`: by the Chebyshev ring of `a`'s square around `vc`, as
/// [`chain_stride`] of the ring's inner distance.
fn edge_stride(vc: (i64, i64), a: DVec2) -> u32 {
    let c = stride_cell(a);
    let ring = (c.0 - vc.0).abs().max((c.1 - vc.1).abs());
    chain_stride((ring - 1).max(0) as f64 * STRIDE_CELL)
}

/// The one stride of every chain starting in `rect` (a bucket, aligned to
/// the stride squares) seen from square `vc`, or `None` when the bucket
/// spans squares of different strides.
fn bucket_stride(vc: (i64, i64), rect: &Rect) -> Option<u32> {
    let lo = stride_cell(rect.min);
    let hi = stride_cell(rect.max);
    let (hx, hy) = (hi.0 - 1, hi.1 - 1);
    let gap = |c: i64, l: i64, h: i64| (l - c).max(c - h).max(0);
    let far = |c: i64, l: i64, h: i64| (c - l).abs().max((c - h).abs());
    let ring_min = gap(vc.0, lo.0, hx.max(lo.0)).max(gap(vc.1, lo.1, hy.max(lo.1)));
    let ring_max = far(vc.0, lo.0, hx.max(lo.0)).max(far(vc.1, lo.1, hy.max(lo.1)));
    let s = |ring: i64| chain_stride((ring - 1).max(0) as f64 * STRIDE_CELL);
    (s(ring_min) == s(ring_max)).then(|| s(ring_min))
}

/// The greatest distance from `v` to the points of the chain of `pieces`
/// pieces starting at edge `e`.
///
/// The square root is taken once, of the greatest squared distance: a
/// correctly rounded square root is monotone, so this is bit for bit the
/// greatest of the distances.
fn chain_reach(index: &SceneIndex, v: DVec2, e: u32, pieces: u32) -> f64 {
    let points = index.ring_points.chain(e, pieces);
    let mut d2_max = (points[0] - v).length_squared();
    for &p in &points[1..] {
        let d2 = (p - v).length_squared();
        if d2 > d2_max {
            d2_max = d2;
        }
    }
    d2_max.sqrt()
}

/// Width in metres of the distance slots of the chain queue.
const CHAIN_SLOT: f64 = 4.0;

/// A chain waiting to enter the horizon: its reach (greatest distance from
/// the sample), its first piece, and its piece count (at most [`MAX_PIECES`], in the
/// top 4 bits) with the bucket it starts in (at most 4 million, in the
/// low 28): 16 bytes, since a sample's queue can hold many thousands.
#[derive(Clone, Copy)]
struct QueuedChain {
    reach: f64,
    first: u32,
    pieces_and_bucket: u32,
}

impl QueuedChain {
    const BUCKET_BITS: u32 = 28;

    fn new(reach: f64, first: u32, pieces: u32, bucket: u32) -> Self {
        debug_assert!(pieces <= MAX_PIECES && bucket < 1 << Self::BUCKET_BITS);
        QueuedChain {
            reach,
            first,
            pieces_and_bucket: pieces << Self::BUCKET_BITS | bucket,
        }
    }

    fn pieces(&self) -> u32 {
        self.pieces_and_bucket >> Self::BUCKET_BITS
    }

    fn bucket(&self) -> u32 {
        self.pieces_and_bucket & ((1 << Self::BUCKET_BITS) - 1)
    }

    /// The chain as one number, for the horizon to hand back
    /// ([`Horizon::holders`]); the reach is left out.
    fn tag(&self) -> u64 {
        self.first as u64 | (self.pieces_and_bucket as u64) << 32
    }

    /// The first piece and the piece count and bucket of a chain's
    /// [`QueuedChain::tag`].
    fn of_tag(tag: u64) -> (u32, QueuedChain) {
        let first = tag as u32;
        let chain = QueuedChain {
            reach: 0.0,
            first,
            pieces_and_bucket: (tag >> 32) as u32,
        };
        (first, chain)
    }
}

/// Chains waiting to enter the horizon, in distance slots: a chain only has
/// to be in the horizon before an item farther than its farthest point is
/// tested, and the order in which chains enter does not change the horizon
/// (a per-bin max), so a coarse order is enough.
struct ChainQueue {
    slots: Vec<Vec<QueuedChain>>,
    /// Every slot below this one is empty.
    first: usize,
    /// Every slot from this one on is empty.
    end: usize,
    len: usize,
    /// The first pieces whose chain was queued since the last
    /// [`ChainQueue::clear`], as a set and as a list (to clear the set).
    queued: ObjectSet,
    marked: Vec<u32>,
}

impl ChainQueue {
    /// An empty queue for a scene of `pieces` occluder pieces.
    fn new(pieces: usize) -> Self {
        ChainQueue {
            slots: Vec::new(),
            first: 0,
            end: 0,
            len: 0,
            queued: ObjectSet::new(pieces),
            marked: Vec::new(),
        }
    }

    fn clear(&mut self) {
        let start = self.first.min(self.end);
        for slot in &mut self.slots[start..self.end] {
            slot.clear();
        }
        self.first = 0;
        self.end = 0;
        self.len = 0;
        for e in self.marked.drain(..) {
            self.queued.remove(e as usize);
        }
    }

    /// Whether the chain starting at piece `e` is queued for the first
    /// time since the last [`ChainQueue::clear`] (a sample gives each first
    /// piece one piece count, so the same first piece is the same chain);
    /// marks it queued.
    fn first_time(&mut self, e: u32) -> bool {
        let fresh = !self.queued.contains(e as usize);
        if fresh {
            self.queued.insert(e as usize);
            self.marked.push(e);
        }
        fresh
    }

    /// Queue the chain of `pieces` pieces starting at piece `e`, at its
    /// reach (computed only here), unless it was queued since the last
    /// [`ChainQueue::clear`]: a second copy would enter no earlier and add
    /// nothing (docs/DESIGN.md, "Chains carried along a run").
    fn push(&mut self, e: u32, pieces: u32, bucket: u32, reach: impl FnOnce() -> f64) {
        if !self.first_time(e) {
            return;
        }
        let d = reach();
        // A chain is never found after items beyond it were tested (the
        // bucket sweep runs ahead); should one be, it simply enters late,
        // which can only leave more visible.
        let slot = ((d.max(0.0) / CHAIN_SLOT) as usize).max(self.first);
        if slot >= self.slots.len() {
            self.slots.resize_with(slot + 1, Vec::new);
        }
        self.slots[slot].push(QueuedChain::new(d, e, pieces, bucket));
        self.end = self.end.max(slot + 1);
        self.len += 1;
    }

    /// Move every chain nearer than `r` into `out`.
    fn take_nearer(&mut self, r: f64, out: &mut Vec<QueuedChain>) {
        if self.len == 0 {
            return;
        }
        let whole = ((r.max(0.0) / CHAIN_SLOT) as usize).min(self.slots.len());
        while self.first < whole {
            let slot = &mut self.slots[self.first];
            self.len -= slot.len();
            out.append(slot);
            self.first += 1;
        }
        if let Some(slot) = self.slots.get_mut(whole) {
            let before = slot.len();
            slot.retain(|&c| {
                if c.reach < r {
                    out.push(c);
                    false
                } else {
                    true
                }
            });
            self.len -= before - slot.len();
        }
    }
}

/// Something waiting in the nearest-first queue.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Item {
    Node(u32),
    /// An object, and whether it was queued at its hull's distance
    /// ([`horizon::object_distance`]).
    Object(u32, bool),
}

/// A non-negative distance as an orderable key (the bits of a non-negative
/// f64 order like the number).
fn key(d: f64) -> u64 {
    d.max(0.0).to_bits()
}

/// What the sweep last found for a node of the bucket hierarchy: at which
/// horizon state it was tested, and whether the horizon hid it then.
#[derive(Clone, Copy, Default)]
struct NodeMark {
    epoch: u64,
    hidden: bool,
}

/// A bucket's or node's chain rectangle up to its height, seen from the
/// sample of `sample_epoch`: its view for the horizon tests (and, from the
/// view's bins, its sectors), found once per sample (the horizon changes
/// during a sample, the rectangle's bins and the slope it needs do not).
/// One is kept per bucket and node for each thread, so it stays small.
#[derive(Clone, Copy, Default)]
struct ViewMark {
    sample_epoch: u64,
    view: RectView,
}
const _: () = assert!(std::mem::size_of::<ViewMark>() == 32);

/// The view of `rect` (not empty) at `height`, seen from `(v, eye)` by the
/// sample of `sample_epoch`: kept in `mark`, made unless it was already.
fn view_mark(
    mark: &mut ViewMark,
    sample_epoch: u64,
    (v, eye): (DVec2, f64),
    rect: &Rect,
    height: f64,
) -> RectView {
    if mark.sample_epoch != sample_epoch {
        *mark = ViewMark {
            sample_epoch,
            view: RectView::new(v, eye, rect, height),
        };
    }
    mark.view
}

/// Reusable per-thread state for solving samples.
pub struct Solver<'a> {
    index: &'a SceneIndex,
    eye: f64,
    near_field: f64,
    pub window: CullWindow,
    horizon: Horizon,
    gathered: Vec<(f64, u32)>,
    queue: BinaryHeap<Reverse<(u64, Item)>>,
    chains: ChainQueue,
    ready: Vec<QueuedChain>,
    /// Per sector of directions, the Chebyshev ring radius out to which
    /// the edge buckets whose chains can meet the sector are swept into
    /// `chains` (docs/DESIGN.md, "Sweeping by direction").
    swept_rings: [i64; SECTORS],
    /// Per edge bucket, the sample epoch at which its chains were queued
    /// (a bucket is queued at most once per sample).
    bucket_queued: Vec<u64>,
    /// Per edge bucket, and per node of each level of the bucket
    /// hierarchy, its chain rectangle's view as seen from the sample of the
    /// epoch kept with it.
    view_marks: [Vec<ViewMark>; NODE_LEVELS + 1],
    /// Per pyramid node, the greatest height of its objects not yet in the
    /// unit's visible set (`NEG_INFINITY` when every one is).
    remaining: Vec<f64>,
    /// Per level of the bucket hierarchy, per node, the sweep's last test.
    node_marks: [Vec<NodeMark>; NODE_LEVELS],
    /// Per bucket, the last test of its chain rectangle when its chains
    /// were taken from the queue.
    bucket_marks: Vec<NodeMark>,
    /// Counts the states of the horizon: one more whenever it is cleared or
    /// chains enter it.
    epoch: u64,
    /// The epoch at which the current sample's horizon was cleared.
    sample_epoch: u64,
    /// Tags ([`QueuedChain::tag`]) of the chains that held the horizon's
    /// bins at the end of the previous sample of the run, queued early for
    /// the next one (docs/DESIGN.md, "Chains carried along a run").
    carried: Vec<u64>,
    /// Tags of the chains that held the bins of the objects this sample
    /// had to sweep for before the horizon hid them, carried to the next
    /// sample with the holders of the whole horizon.
    carried_next: Vec<u64>,
}

impl<'a> Solver<'a> {
    pub fn new(index: &'a SceneIndex, eye: f64, near_field: f64) -> Self {
        Solver {
            index,
            eye,
            near_field,
            window: CullWindow::new(index.grid),
            horizon: Horizon::default(),
            gathered: Vec::new(),
            queue: BinaryHeap::new(),
            chains: ChainQueue::new(index.edges.len()),
            ready: Vec::new(),
            swept_rings: [-1; SECTORS],
            bucket_queued: vec![0; index.bucket_count()],
            view_marks: std::array::from_fn(|l| {
                let len = if l < NODE_LEVELS {
                    index.bucket_nodes(l).len()
                } else {
                    index.bucket_count()
                };
                vec![ViewMark::default(); len]
            }),
            remaining: Vec::new(),
            node_marks: std::array::from_fn(|l| {
                vec![NodeMark::default(); index.bucket_nodes(l).len()]
            }),
            bucket_marks: vec![NodeMark::default(); index.bucket_count()],
            epoch: 1,
            sample_epoch: 1,
            carried: Vec::new(),
            carried_next: Vec::new(),
        }
    }

    /// With `false`, no bucket, node of the bucket hierarchy or chain is
    /// skipped for lying below the horizon: every chain the search reaches
    /// enters the horizon in full. Slower; the visible sets must be the
    /// same (those skips only leave out chains that cannot raise the
    /// horizon, so every bin is the same at every step of the search),
    /// which is what tests check.
    pub fn set_skip_hidden(&mut self, skip: bool) {
        // One switch, kept by the horizon, read by the sweep too.
        self.horizon.skip_hidden = skip;
    }

    /// Add to `visible` every object not hidden from the sample at `v`.
    pub fn solve(&mut self, v: DVec2, visible: &mut ObjectSet) {
        self.solve_run(&[v], visible);
    }

    /// The chains this solver carries to the next sample it solves (the
    /// holders of the last sample's horizon and of what hid its objects;
    /// "Chains carried along a run").
    pub fn carried(&self) -> &[u64] {
        &self.carried
    }

    /// Carry `tags` (a list [`Solver::carried`] gave, maybe of another
    /// solver of the same scene) to the next sample instead. Carried chains
    /// change only how soon "hidden" is found, never a verdict.
    pub fn set_carried(&mut self, tags: &[u64]) {
        self.carried.clear();
        self.carried.extend_from_slice(tags);
    }

    /// Add to `visible` every object not hidden from some point of `points`
    /// (the samples of one unit: in order along a straight segment, or a
    /// single point). Each sample decides only the objects not yet in
    /// `visible`: later samples skip what earlier ones saw, and a pyramid
    /// node is tested with the greatest height of its objects still to be
    /// decided. The result depends on the points (in the order given), the
    /// objects already in `visible` and the scene only: what the solver
    /// solved before (the chains it carries over) changes only how soon
    /// "hidden" is found, never a verdict.
    pub fn solve_run(&mut self, points: &[DVec2], visible: &mut ObjectSet) {
        let index = self.index;
        self.remaining.clear();
        self.remaining
            .extend(index.pyramid.iter().map(|n| n.max_height));
        let mut leaves: Vec<u32> = visible
            .to_vec()
            .into_iter()
            .filter(|&o| (o as usize) < index.objects.len())
            .map(|o| index.object_leaf[o as usize])
            .collect();
        leaves.sort_unstable();
        leaves.dedup();
        for leaf in leaves {
            self.refresh_remaining(leaf, visible);
        }
        for &p in points {
            self.solve_point(p, None, visible);
            self.carry_on();
        }
    }

    /// Keep the chains that hold the horizon now, with those that hid the
    /// objects swept for, to queue them early for the next sample this
    /// solver solves (the next of the run, or the first of the next unit,
    /// nearby in the cells' order): a few hundred chains that, seen from
    /// 2 m further on, hide nearly all they hid here. Only how soon
    /// "hidden" is found depends on them, never a verdict.
    fn carry_on(&mut self) {
        self.carried.clear();
        self.carried.append(&mut self.carried_next);
        self.horizon.holders(&mut self.carried);
        self.carried.sort_unstable();
        self.carried.dedup();
    }

    /// One point, with only the objects `undecided` still to decide (every
    /// other object must be in `visible`) and only the horizon bins
    /// `interest` read, when given (they must hold the bins of every object
    /// of `undecided`): adds to `visible` each of them not hidden from `v`,
    /// with the verdict [`Solver::solve_run`] gives it.
    pub fn solve_point_for(
        &mut self,
        v: DVec2,
        interest: Option<(i64, i64)>,
        undecided: &[u32],
        visible: &mut ObjectSet,
    ) {
        // Per node, the greatest height of the undecided objects below it:
        // what `solve_run` finds from the visible set, built from the few
        // undecided objects instead.
        let index = self.index;
        self.remaining.clear();
        self.remaining
            .resize(index.pyramid.len(), f64::NEG_INFINITY);
        for &o in undecided {
            let height = index.objects[o as usize].height;
            let mut n = index.object_leaf[o as usize];
            while n != NO_PARENT && self.remaining[n as usize] < height {
                self.remaining[n as usize] = height;
                n = index.parent[n as usize];
            }
        }
        self.solve_point(v, interest, visible);
        self.carry_on();
    }

    /// Recompute the greatest height of the objects not yet visible under
    /// `node` (a leaf) and its ancestors; `NEG_INFINITY` where none is left.
    fn refresh_remaining(&mut self, node: u32, visible: &ObjectSet) {
        let index = self.index;
        let leaf = &index.pyramid[node as usize];
        let mut top = leaf
            .objects
            .iter()
            .filter(|&&o| !visible.contains(o as usize))
            .map(|&o| index.objects[o as usize].height)
            .fold(f64::NEG_INFINITY, f64::max);
        for &c in &leaf.children {
            top = top.max(self.remaining[c as usize]);
        }
        let mut n = node;
        loop {
            if self.remaining[n as usize] == top {
                return;
            }
            self.remaining[n as usize] = top;
            n = index.parent[n as usize];
            if n == NO_PARENT {
                return;
            }
            let node = &index.pyramid[n as usize];
            top = node
                .children
                .iter()
                .map(|&c| self.remaining[c as usize])
                .fold(f64::NEG_INFINITY, f64::max);
            top = node
                .objects
                .iter()
                .filter(|&&o| !visible.contains(o as usize))
                .map(|&o| index.objects[o as usize].height)
                .fold(top, f64::max);
        }
    }

    /// One sample: add every object not yet in `visible` that is not hidden
    /// from `v` (reading only the bins `interest`, when given).
    fn solve_point(&mut self, v: DVec2, interest: Option<(i64, i64)>, visible: &mut ObjectSet) {
        // The cull map is drawn only when a not yet visible object that
        // overlaps the window is tested.
        self.window.place_around(v, self.near_field);
        self.carried_next.clear();
        let mut drawn = false;
        self.horizon.clear();
        if let Some(bins) = interest {
            self.horizon.restrict_to_bins(bins);
        }
        self.epoch += 1;
        self.sample_epoch = self.epoch;
        self.chains.clear();
        self.swept_rings = [-1; SECTORS];
        self.queue.clear();
        let Some(root) = self.index.root else { return };
        let index = self.index;
        self.queue_carried(v);
        self.queue.push(Reverse((
            key(rect_distance(v, &index.pyramid[root as usize].rect)),
            Item::Node(root),
        )));
        let window = self.window.rect();
        while let Some(Reverse((k, item))) = self.queue.pop() {
            let r = f64::from_bits(k);
            match item {
                Item::Node(n) => {
                    // Only the objects not yet visible are left to decide:
                    // the node hides them if it hides their greatest height.
                    let top = self.remaining[n as usize];
                    if top == f64::NEG_INFINITY {
                        continue;
                    }
                    let node = &index.pyramid[n as usize];
                    let view = RectView::new(v, self.eye, &node.rect, top);
                    if self.hidden_by_chains_found(v, r, &view) {
                        continue;
                    }
                    for &c in &node.children {
                        if self.remaining[c as usize] != f64::NEG_INFINITY {
                            let d = rect_distance(v, &index.pyramid[c as usize].rect);
                            self.queue.push(Reverse((key(d), Item::Node(c))));
                        }
                    }
                    for &o in &node.objects {
                        if !visible.contains(o as usize) {
                            let (d, outside) = index.objects[o as usize].distance_from(v);
                            self.queue.push(Reverse((key(d), Item::Object(o, outside))));
                        }
                    }
                }
                Item::Object(o, outside) => {
                    if visible.contains(o as usize) {
                        continue;
                    }
                    if !self.object_hidden(v, (r, outside), o, &window, &mut drawn) {
                        visible.insert(o as usize);
                        self.refresh_remaining(index.object_leaf[o as usize], visible);
                    }
                }
            }
        }
    }

    /// Queue the chains carried from the previous sample that are chains
    /// of the sample at `v` too (the stride `v` gives their first piece is
    /// theirs); they wait, like any other, until the search passes their
    /// farthest point. The others are dropped.
    fn queue_carried(&mut self, v: DVec2) {
        let index = self.index;
        let vc = stride_cell(v);
        for &tag in &self.carried {
            let (e, c) = QueuedChain::of_tag(tag);
            let pieces = c.pieces();
            if edge_stride(vc, index.edge_first_point(e)) + 1 == pieces {
                self.chains
                    .push(e, pieces, c.bucket(), || chain_reach(index, v, e, pieces));
            }
        }
    }

    /// True when the object is hidden: by the horizon over the bins of its
    /// hull (of its rectangle when `v` is inside the hull), at `r`, the
    /// distance it was queued at ([`super::index::ObjectRaster::distance_from`]; valid for any
    /// object, docs/METHOD.md §6), or, when it lies wholly inside the
    /// window, pixel by pixel by the cull map. (An object reaching out of
    /// the window needs the horizon for its outside part, and the horizon
    /// over the whole object then suffices.) So the
    /// verdict reads only the object, the horizon at its distance and the
    /// cull map, and a hidden pyramid node implies it for each object below.
    fn object_hidden(
        &mut self,
        v: DVec2,
        (r, outside_hull): (f64, bool),
        o: u32,
        window: &Rect,
        drawn: &mut bool,
    ) -> bool {
        let index = self.index;
        let object = &index.objects[o as usize];
        let view = object.view_from(v, self.eye, (r, outside_hull));
        if !contains(window, &object.rect) {
            return self.hidden_by_chains_nearer(v, r, &view);
        }
        if self.hidden_by_chains_found(v, r, &view) {
            return true;
        }
        if !*drawn {
            self.window.clear_heights();
            self.rasterise_occluders(v);
            *drawn = true;
        }
        let mut outside = false;
        self.window
            .spans_hidden(&object.spans, object.height, &mut outside)
            || self.hidden_by_chains_nearer(v, r, &view)
    }

    /// Whether the horizon of the chains nearer than `r` (the distance of
    /// the item of `view`) hides that item up to its top (both
    /// seen from `v`, found once per item). The horizon is first asked as it
    /// is: it holds some of those chains only (it is never grown past the
    /// distance of the item being tested, and items come nearest first),
    /// and a horizon of fewer chains is lower in every bin, so "hidden"
    /// there is already the answer. Only otherwise is it grown to `r` and
    /// asked again (docs/DESIGN.md, "Growing the horizon only when asked").
    fn hidden_by_chains_nearer(&mut self, v: DVec2, r: f64, view: &RectView) -> bool {
        let hidden = self.grow_until_hidden(v, r, view);
        if hidden && let Some(bins) = view.bins() {
            // The chains holding the object's bins now are carried on to
            // the next sample with the holders of the whole horizon
            // (docs/DESIGN.md, "Chains carried along a run").
            self.horizon.holders_in(bins, &mut self.carried_next);
        }
        hidden
    }

    /// [`Solver::hidden_by_chains_nearer`] without the note of what hid it.
    fn grow_until_hidden(&mut self, v: DVec2, r: f64, view: &RectView) -> bool {
        if self.hidden_by_chains_found(v, r, view) {
            return true;
        }
        // Ring by ring, the chains nearer than r enter as they are found,
        // and the item is asked again whenever the horizon changed:
        // "hidden" is final at once, "not hidden" only once every ring out
        // to r is swept. Only the chains that can meet the item's
        // directions decide it: the sweep goes out to r in the item's
        // sectors only (in every direction with the skips off, for tests
        // to compare with).
        // Within those, only the sectors where the horizon is still below
        // the item need it to grow; they shrink as chains enter
        // (docs/DESIGN.md, "Sweeping only where the object still shows").
        let skip = self.horizon.skip_hidden;
        let mut sectors = if skip {
            self.horizon.failing_sectors(view)
        } else {
            ALL_SECTORS
        };
        while self.sweep_one_more_ring(v, r, sectors) {
            if self.enter_chains_nearer(v, r) {
                // The failing sectors are empty exactly when the horizon
                // hides the item: one scan answers both questions.
                if skip {
                    sectors = self.horizon.failing_sectors(view);
                    if sectors == 0 {
                        return true;
                    }
                } else if self.horizon.hides_view(view) {
                    return true;
                }
            }
        }
        false
    }

    /// Whether the chains found so far hide the rectangle of `view` (at
    /// distance `r`) up to its top: first those in the horizon, then with
    /// the queued ones nearer than `r` entered, asked again only if they
    /// changed it. No bucket is
    /// swept. A pyramid node is tested only this way: a node only saves
    /// work (when it is not shown hidden, its children and objects are
    /// queued and each object gets its own full test), so a node never
    /// makes the search sweep farther; only objects do.
    fn hidden_by_chains_found(&mut self, v: DVec2, r: f64, view: &RectView) -> bool {
        self.horizon.hides_view(view)
            || (self.enter_chains_nearer(v, r) && self.horizon.hides_view(view))
    }

    /// Sweep one more ring of edge buckets for the sectors of `sectors`
    /// that lag furthest behind, when the rings swept for them so far do
    /// not yet hold every chain nearer than `r` that can meet them; false
    /// when they do (every such chain is then queued or in).
    fn sweep_one_more_ring(&mut self, v: DVec2, r: f64, sectors: Sectors) -> bool {
        let index = self.index;
        let rings_needed =
            ((r / index.bucket_size()).ceil() as i64 + 1).min(index.max_bucket_ring(v));
        let mut lagging: Sectors = 0;
        let mut ring = i64::MAX;
        let mut rest = sectors;
        while rest != 0 {
            let s = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let swept = self.swept_rings[s];
            if swept < rings_needed {
                if swept + 1 < ring {
                    ring = swept + 1;
                    lagging = 0;
                }
                if swept + 1 == ring {
                    lagging |= 1 << s;
                }
            }
        }
        if lagging == 0 {
            return false;
        }
        let mut sweep = Sweep {
            index,
            v,
            vc: stride_cell(v),
            eye: self.eye,
            epoch: self.epoch,
            sample_epoch: self.sample_epoch,
            sectors: lagging,
            horizon: &self.horizon,
            marks: &mut self.node_marks,
            queued: &mut self.bucket_queued,
            view_marks: &mut self.view_marks,
            chains: &mut self.chains,
        };
        sweep.ring(ring);
        let mut rest = lagging;
        while rest != 0 {
            let s = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            self.swept_rings[s] = ring;
        }
        true
    }

    /// Add to the horizon every queued chain whose farthest vertex is
    /// nearer than `r`; true when any entered (the horizon's state, its
    /// epoch, then moved on).
    fn enter_chains_nearer(&mut self, v: DVec2, r: f64) -> bool {
        let index = self.index;
        let mut ready = std::mem::take(&mut self.ready);
        ready.clear();
        self.chains.take_nearer(r, &mut ready);
        let entered = !ready.is_empty();
        if entered {
            if self.horizon.skip_hidden {
                // The horizon may have grown since a chain's bucket was
                // swept: a bucket (or node) that it hides now holds no chain
                // that could raise it (docs/DESIGN.md, "The bucket
                // hierarchy").
                // The chains of one bucket mostly come one after another:
                // the answer for the last bucket is the one its marks give
                // again (the horizon does not change here). Asking the
                // bucket's own mark first inside `chain_bucket_hidden`, for
                // every chain, measured slower: a scattered read per chain.
                let (eye, epoch, sample_epoch) = (self.eye, self.epoch, self.sample_epoch);
                let mut last: Option<(u32, bool)> = None;
                ready.retain(|c| {
                    let bucket = c.bucket();
                    let hidden = match last {
                        Some((b, hidden)) if b == bucket => hidden,
                        _ => chain_bucket_hidden(
                            index,
                            &self.horizon,
                            (&mut self.node_marks, &mut self.bucket_marks),
                            &mut self.view_marks,
                            (v, eye),
                            (epoch, sample_epoch),
                            bucket as usize,
                        ),
                    };
                    last = Some((bucket, hidden));
                    !hidden
                });
            }
            add_ready_chains(&mut self.horizon, index, v, self.eye, &ready);
            self.epoch += 1;
        }
        self.ready = ready;
        entered
    }

    /// True when every object of `objects` (indices into the index) is
    /// hidden from `v` by the horizon of the chains nearer than it, by the
    /// object's own test (its hull and the distance it is queued at, as in
    /// [`Solver::object_hidden`] for an object outside the window) with a
    /// margin against rounding ([`RectView::strictly`]). Only chains that
    /// can meet the directions of some object's rectangle are added (any
    /// subset of the chains gives a valid, lower horizon), and each object
    /// is tested, nearest first, against the chains nearer than it. So a
    /// `true` here implies that the solver's own horizon test of each object
    /// says hidden. With [`Solver::set_skip_hidden`]`(false)` every ring out
    /// to each object is swept and every chain added before it is tested
    /// (the same answers, slower).
    pub fn probe_hidden(&mut self, v: DVec2, objects: &[u32]) -> bool {
        let index = self.index;
        let eye = self.eye;
        // Each object's distance, its place in `objects` (for a fixed
        // order among equal distances) and its view.
        let mut members: Vec<(f64, usize, RectView)> = Vec::with_capacity(objects.len());
        let mut targets = Vec::with_capacity(objects.len());
        // The union of all the rectangles, up to the highest top.
        let mut union = Rect::EMPTY;
        let mut highest = f64::NEG_INFINITY;
        for (k, &o) in objects.iter().enumerate() {
            let object = &index.objects[o as usize];
            let Some(bins) = rect_bins(v, &object.rect) else {
                return false;
            };
            targets.push(bins);
            let at = object.distance_from(v);
            members.push((at.0, k, object.view_from(v, eye, at).strictly()));
            union = union.union(&object.rect);
            highest = highest.max(object.height);
        }
        members.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let union_bins = rect_bins(v, &union);
        // First the union of all the rectangles, at its (nearest) distance,
        // up to the highest top: if the horizon hides that, it hides each
        // object (its hull lies in a sub-rectangle, no nearer, no higher;
        // the horizon at a greater distance holds more chains), without
        // sweeping out to the farthest one.
        let mut tests: Vec<(f64, RectView, bool)> = Vec::with_capacity(members.len() + 1);
        if objects.len() > 1
            && let Some(bins) = union_bins
        {
            targets.push(bins);
            let view = RectView::new(v, eye, &union, highest).strictly();
            tests.push((rect_distance(v, &union), view, true));
        }
        tests.extend(members.iter().map(|&(r, _, view)| (r, view, false)));
        // A chain nearer than a rectangle that meets its directions has its
        // points there inside the hull of `v` and the rectangle, and starts
        // within a chain's length of them.
        let mut hull = union;
        hull.include(v);
        let hull = hull.grown(4.0 * MAX_EDGE_PIECE + 1.0);
        self.horizon.clear();
        // Only the bins of the rectangles are read below: those of their
        // union hold them all. (Not with the skips off: then every chain is
        // added and every ring swept, for tests to compare with.)
        let skips = self.horizon.skip_hidden;
        if skips && let Some(bins) = union_bins {
            self.horizon.restrict_to_bins(bins);
        }
        self.chains.clear();
        // The chains that held the previous probe's bins, when they are
        // this sample's own chains (only how soon "hidden" is found
        // depends on them: they are real chains nearer than the rectangle
        // when they enter).
        self.queue_carried(v);
        let vc = stride_cell(v);
        let max_ring = index.max_bucket_ring(v);
        let mut swept = -1;
        let mut ready = std::mem::take(&mut self.ready);
        let mut result = true;
        for &(r, ref view, is_union) in &tests {
            let rings = ((r / index.bucket_size()).ceil() as i64 + 1).min(max_ring);
            // Each test is made again after every ring: the chains nearer
            // than it found so far are some of those nearer than it, whose
            // horizon is no lower in any bin, so "hidden" by them is final.
            // "Not hidden" is final only once every ring out to it is swept.
            let hidden = loop {
                ready.clear();
                self.chains.take_nearer(r, &mut ready);
                add_ready_chains(&mut self.horizon, index, v, eye, &ready);
                let hidden = self.horizon.hides_view(view);
                if (hidden && skips) || swept >= rings {
                    break hidden;
                }
                swept += 1;
                let (chains, horizon) = (&mut self.chains, &self.horizon);
                index.buckets_in_ring(v, swept, |bucket| {
                    let height = index.bucket_height(bucket);
                    if height <= eye || !index.bucket_rect(bucket).intersects(&hull) {
                        return;
                    }
                    let reach = index.bucket_chain_rect(bucket, None);
                    if reach.is_empty() {
                        return;
                    }
                    // The cheaper test first: the bucket's chains can raise
                    // no bin the members' tests read.
                    if let Some(bins) = rect_bins(v, reach)
                        && !targets.iter().any(|&t| bins_overlap(bins, t))
                    {
                        return;
                    }
                    if horizon.hides_rect(v, eye, reach, height) {
                        return;
                    }
                    let stride = bucket_stride(vc, &index.bucket_rect(bucket));
                    queue_bucket_chains(index, v, vc, eye, (bucket, stride), chains);
                });
            };
            if is_union {
                if hidden {
                    break;
                }
                continue;
            }
            if !hidden {
                result = false;
                break;
            }
        }
        self.ready = ready;
        self.carry_on();
        self.horizon.clear();
        self.chains.clear();
        result
    }

    /// Fill the window with U_V from the occluder edges that reach into it,
    /// nearest first, dropping edges whose top is already hidden.
    pub fn rasterise_occluders(&mut self, v: DVec2) {
        let index = self.index;
        let rect = self.window.rect();
        self.gathered.clear();
        let gathered = &mut self.gathered;
        // An edge whose box overlaps several buckets is met once per
        // bucket; its copies sort next to each other (the same distance,
        // geometry and number) and are dropped after the sort, which keeps
        // no per-edge mark in each solver.
        // Only the edges that can draw are kept: silhouette edges (where
        // H > h those that face the eye, where H <= h those that face
        // away) that meet the window. An edge whose box misses the window
        // casts no shadow into it: a point of the shadow lies beyond the
        // edge on a ray from the eye, which meets the edge first, and the
        // window is convex and holds the eye (it is placed around the
        // sample; a picture's window around a cell holds the cell's
        // samples), so it would hold that point of the edge too. Leaving
        // the others out before the sort keeps the order of the rest, so
        // the same edges are drawn and dropped in the same order.
        debug_assert!(rect.contains_point(v), "the eye lies outside the window");
        let eye = self.eye;
        index.edges_near(&rect, |e| {
            let (a, b) = index.edge_points(e);
            let height = index.edges[e as usize].height;
            // The solid is on the edge's left; the eye faces the edge's
            // outside when it is on its right.
            let eye_outside = (b - a).perp_dot(v - a) < 0.0;
            let silhouette = if height > eye {
                eye_outside
            } else {
                !eye_outside
            };
            if silhouette && Rect::of_points(&[a, b]).intersects(&rect) {
                gathered.push((distance_to_segment(v, a, b), e));
            }
        });
        // Ties in distance are broken by the edges' own coordinates, not by
        // their numbering, so the drawing order (and the drops) depend on the
        // edges only, not on what else the city holds. The order is total
        // (the edge's number decides last, and two entries equal under it
        // are copies of one edge), so an unstable sort gives the same order
        // as a stable one, without the stable sort's buffer.
        let geometry = |e: u32| {
            let (a, b) = index.edge_points(e);
            [a.x, a.y, b.x, b.y, index.edges[e as usize].height]
        };
        self.gathered.sort_unstable_by(|x, y| {
            x.0.total_cmp(&y.0).then_with(|| {
                let (gx, gy) = (geometry(x.1), geometry(y.1));
                gx.iter()
                    .zip(&gy)
                    .map(|(p, q)| p.total_cmp(q))
                    .find(|o| o.is_ne())
                    .unwrap_or(std::cmp::Ordering::Equal)
                    .then(x.1.cmp(&y.1))
            })
        });
        self.gathered.dedup_by_key(|x| x.1);
        for &(_, e) in &self.gathered {
            let (a, b) = index.edge_points(e);
            let height = index.edges[e as usize].height;
            if !self.window.segment_hidden(a, b, height) {
                self.window.rasterise_shadow(v, self.eye, a, b, height);
            }
        }
    }
}

/// Queue every chain that starts in `bucket` (at the pieces its stride
/// picks, from the absolute square `vc` of the eye) with its reach;
/// `stride` is the bucket's [`bucket_stride`] from `vc`.
fn queue_bucket_chains(
    index: &SceneIndex,
    v: DVec2,
    vc: (i64, i64),
    eye: f64,
    (bucket, stride): (usize, Option<u32>),
    chains: &mut ChainQueue,
) {
    // Where the bucket lies in squares of one stride only (most buckets
    // away from the eye), its chains start at the edges of that stride's
    // prefix of the bucket's list: the same chains, found without testing
    // each edge.
    if let Some(stride) = stride {
        let pieces = stride + 1;
        for e in index.bucket_starts_strided(bucket, stride) {
            if index.edges[e as usize].height > eye {
                chains.push(e, pieces, bucket as u32, || {
                    chain_reach(index, v, e, pieces)
                });
            }
        }
        return;
    }
    for e in index.bucket_starts(bucket) {
        let edge = &index.edges[e as usize];
        let stride = edge_stride(vc, index.edge_first_point(e));
        if !edge.ring_pos.is_multiple_of(stride) || edge.height <= eye {
            continue;
        }
        let pieces = stride + 1;
        chains.push(e, pieces, bucket as u32, || {
            chain_reach(index, v, e, pieces)
        });
    }
}

/// Where the stretch of walk positions from `i` onwards that shares its
/// node of `level` with `i` ends, at most at `end` (positions are columns
/// along a row or rows along a column, and nodes are aligned to them).
fn stretch_end(level: usize, i: usize, end: usize) -> usize {
    let side = 1usize << NODE_SHIFTS[level];
    (i | (side - 1)).min(end)
}

/// One ring of the bucket sweep around a sample, against the horizon as it
/// stands: every bucket of the ring in the order of
/// [`SceneIndex::buckets_in_ring`], except those under a node of the
/// bucket hierarchy that the horizon hides (skipped a node's stretch of the
/// ring at a time).
struct Sweep<'s, 'a> {
    index: &'a SceneIndex,
    v: DVec2,
    vc: (i64, i64),
    eye: f64,
    epoch: u64,
    sample_epoch: u64,
    /// The sectors swept for: a bucket whose chains meet none of them is
    /// passed over (left for a sweep of its own sectors).
    sectors: Sectors,
    horizon: &'s Horizon,
    marks: &'s mut [Vec<NodeMark>; NODE_LEVELS],
    queued: &'s mut [u64],
    view_marks: &'s mut [Vec<ViewMark>; NODE_LEVELS + 1],
    chains: &'s mut ChainQueue,
}

impl Sweep<'_, '_> {
    /// Whether the horizon hides the node of `level` holding bucket
    /// `(x, y)`: tested at most once per horizon state, and a node once
    /// hidden stays hidden for the rest of the sample (the horizon only
    /// grows).
    fn node_hidden(&mut self, level: usize, x: usize, y: usize) -> bool {
        if !self.horizon.skip_hidden {
            return false;
        }
        let nodes = self.index.bucket_nodes(level);
        let n = nodes.node_of(x, y);
        let mark = &mut self.marks[level][n];
        if mark.epoch == self.epoch || (mark.hidden && mark.epoch >= self.sample_epoch) {
            return mark.hidden;
        }
        let height = nodes.height(n);
        let rect = nodes.rect(n);
        let hidden = height <= self.eye
            || rect.is_empty()
            || self.horizon.hides_view(&view_mark(
                &mut self.view_marks[level][n],
                self.sample_epoch,
                (self.v, self.eye),
                rect,
                height,
            ));
        *mark = NodeMark {
            epoch: self.epoch,
            hidden,
        };
        hidden
    }

    /// The sectors of `rect` (the chain rectangle of a node of `level`, or
    /// of a bucket for `level` = `NODE_LEVELS`, number `n`, whose height is
    /// `height`), from its view, found once per sample.
    fn sectors_of(&mut self, level: usize, n: usize, rect: &Rect, height: f64) -> Sectors {
        if rect.is_empty() {
            return 0;
        }
        view_mark(
            &mut self.view_marks[level][n],
            self.sample_epoch,
            (self.v, self.eye),
            rect,
            height,
        )
        .sectors()
    }

    /// Whether the node of `level` holding bucket `(x, y)` is passed over:
    /// its chains meet none of the sectors swept for, or the horizon hides
    /// it.
    fn node_skipped(&mut self, level: usize, x: usize, y: usize) -> bool {
        if self.sectors != ALL_SECTORS {
            let nodes = self.index.bucket_nodes(level);
            let n = nodes.node_of(x, y);
            if self.sectors_of(level, n, nodes.rect(n), nodes.height(n)) & self.sectors == 0 {
                return true;
            }
        }
        self.node_hidden(level, x, y)
    }

    /// Test bucket `(x, y)` and queue its chains unless it (or a node
    /// holding it) is below the horizon, its chains meet none of the
    /// sectors swept for, or they are queued already.
    fn bucket(&mut self, x: usize, y: usize) {
        // First the bucket's nodes in the hierarchy, largest first: a node
        // whose rectangle and height the horizon hides holds no chain that
        // could raise it, now or later in this sample (docs/DESIGN.md, "The
        // bucket hierarchy").
        if (0..NODE_LEVELS)
            .rev()
            .any(|level| self.node_skipped(level, x, y))
        {
            return;
        }
        self.bucket_under_open_nodes(x, y);
    }

    /// [`Sweep::bucket`] for a bucket whose nodes were just found not
    /// passed over (by [`Sweep::walk`], at this horizon state, so testing
    /// them again would give the same answer).
    fn bucket_under_open_nodes(&mut self, x: usize, y: usize) {
        let (index, v, eye) = (self.index, self.v, self.eye);
        let bucket = index.bucket_index(x, y);
        if self.queued[bucket] == self.sample_epoch {
            return;
        }
        let height = index.bucket_height(bucket);
        if height <= eye {
            return;
        }
        // Every chain the bucket can start lies in its chain rectangle over
        // all strides, so its directions lie in that rectangle's sectors.
        if self.sectors != ALL_SECTORS
            && self.sectors_of(
                NODE_LEVELS,
                bucket,
                index.bucket_chain_rect(bucket, None),
                height,
            ) & self.sectors
                == 0
        {
            return;
        }
        // Every chain that starts in this bucket lies in its chain
        // rectangle and is no higher than the bucket's highest edge: if
        // that is all below the horizon already, no chain of the bucket can
        // raise it (the horizon only grows).
        let stride = bucket_stride(self.vc, &index.bucket_rect(bucket));
        let reach = index.bucket_chain_rect(bucket, stride);
        if reach.is_empty()
            || (self.horizon.skip_hidden && self.horizon.hides_rect(v, eye, reach, height))
        {
            return;
        }
        self.queued[bucket] = self.sample_epoch;
        queue_bucket_chains(index, v, self.vc, eye, (bucket, stride), self.chains);
    }

    /// Walk buckets `at(lo)..=at(hi)` along one row or column, jumping over
    /// the stretches whose nodes are passed over. A node found not passed
    /// over is not asked again for the other buckets of its stretch: the
    /// horizon does not change during a walk, so it would answer the same.
    fn walk(&mut self, lo: usize, hi: usize, at: impl Fn(usize) -> (usize, usize)) {
        // Per level, the last position of the stretch whose node was found
        // not passed over.
        let mut open_until: [Option<usize>; NODE_LEVELS] = [None; NODE_LEVELS];
        let mut i = lo;
        'walk: while i <= hi {
            let bucket = at(i);
            for level in (0..NODE_LEVELS).rev() {
                if open_until[level].is_some_and(|last| i <= last) {
                    continue;
                }
                // The node's stretch is passed over whole, or left open.
                let last = stretch_end(level, i, hi);
                if self.node_skipped(level, bucket.0, bucket.1) {
                    i = last + 1;
                    continue 'walk;
                }
                open_until[level] = Some(last);
            }
            self.bucket_under_open_nodes(bucket.0, bucket.1);
            i += 1;
        }
    }

    /// Every bucket at Chebyshev distance exactly `ring` from the sample's
    /// bucket: the bottom row, then the top row, left to right, then the
    /// left and the right column upwards. The order changes no verdict:
    /// the horizon does not change during a ring, and it is a per-bin max
    /// whatever the order in which chains enter; at most it changes which
    /// of two equally steep chains holds a bin and is carried on.
    fn ring(&mut self, ring: i64) {
        let (nx, ny) = self.index.bucket_dims();
        let (nx, ny) = (nx as i64, ny as i64);
        let (cx, cy) = self.index.bucket_cell_of(self.v);
        let inside = |c: i64, n: i64| (c >= 0 && c < n).then_some(c as usize);
        if ring == 0 {
            if let (Some(x), Some(y)) = (inside(cx, nx), inside(cy, ny)) {
                self.bucket(x, y);
            }
            return;
        }
        let rows = [inside(cy - ring, ny), inside(cy + ring, ny)];
        let (x0, x1) = ((cx - ring).max(0), (cx + ring).min(nx - 1));
        if x0 <= x1 {
            for row in rows.into_iter().flatten() {
                self.walk(x0 as usize, x1 as usize, |i| (i, row));
            }
        }
        let columns = [inside(cx - ring, nx), inside(cx + ring, nx)];
        let (y0, y1) = ((cy - ring + 1).max(0), (cy + ring - 1).min(ny - 1));
        if y0 <= y1 {
            for column in columns.into_iter().flatten() {
                self.walk(y0 as usize, y1 as usize, |i| (column, i));
            }
        }
    }
}

/// Whether the horizon now hides bucket `bucket`'s node of either level or
/// its chain rectangle over all strides at its height, remembered per
/// horizon state in `node_marks` and `bucket_marks` (a hidden mark stays
/// valid for the rest of the sample: the horizon only grows).
fn chain_bucket_hidden(
    index: &SceneIndex,
    horizon: &Horizon,
    (node_marks, bucket_marks): (&mut [Vec<NodeMark>; NODE_LEVELS], &mut [NodeMark]),
    view_marks: &mut [Vec<ViewMark>; NODE_LEVELS + 1],
    (v, eye): (DVec2, f64),
    (epoch, sample_epoch): (u64, u64),
    bucket: usize,
) -> bool {
    let test = |mark: &mut NodeMark, view: &mut ViewMark, rect: &Rect, height: f64| {
        if mark.epoch == epoch || (mark.hidden && mark.epoch >= sample_epoch) {
            return mark.hidden;
        }
        let hidden = height <= eye
            || rect.is_empty()
            || horizon.hides_view(&view_mark(view, sample_epoch, (v, eye), rect, height));
        *mark = NodeMark { epoch, hidden };
        hidden
    };
    let (x, y) = index.bucket_key(bucket);
    for level in (0..NODE_LEVELS).rev() {
        let nodes = index.bucket_nodes(level);
        let n = nodes.node_of(x, y);
        if test(
            &mut node_marks[level][n],
            &mut view_marks[level][n],
            nodes.rect(n),
            nodes.height(n),
        ) {
            return true;
        }
    }
    test(
        &mut bucket_marks[bucket],
        &mut view_marks[NODE_LEVELS][bucket],
        index.bucket_chain_rect(bucket, None),
        index.bucket_height(bucket),
    )
}

/// Add the chains taken from the queue (first piece, piece count) to the
/// horizon seen from `(v, eye)`.
fn add_ready_chains(
    horizon: &mut Horizon,
    index: &SceneIndex,
    v: DVec2,
    eye: f64,
    ready: &[QueuedChain],
) {
    for c in ready {
        let height = index.edges[c.first as usize].height;
        let chain = index.ring_points.chain(c.first, c.pieces());
        horizon.add_chain(v, eye, height, c.tag(), chain);
    }
}

/// Distance from `v` to the nearest point of `rect` (0 inside): the
/// distance at which an item is tested, and chains nearer than it enter.
pub(crate) fn rect_distance(v: DVec2, rect: &Rect) -> f64 {
    v.clamp(rect.min, rect.max).distance(v)
}

fn contains(outer: &Rect, inner: &Rect) -> bool {
    inner.min.x >= outer.min.x
        && inner.min.y >= outer.min.y
        && inner.max.x <= outer.max.x
        && inner.max.y <= outer.max.y
}

#[cfg(test)]
mod tests {
    use super::ChainQueue;

    #[test]
    fn a_chain_is_queued_once_until_the_queue_is_cleared() {
        let mut queue = ChainQueue::new(200);
        assert!(queue.first_time(3));
        assert!(!queue.first_time(3));
        assert!(queue.first_time(64));
        assert!(queue.first_time(65));
        assert!(!queue.first_time(64));
        assert!(queue.first_time(199));
        queue.clear();
        for e in [3, 64, 65, 199] {
            assert!(queue.first_time(e), "piece {e} after clear");
        }
        assert!(!queue.first_time(65));
    }

    #[test]
    fn queued_chains_come_out_once_nearest_slots_first() {
        let mut queue = ChainQueue::new(8);
        for (d, e) in [(30.0, 1), (2.0, 2), (9.5, 3), (9.0, 4)] {
            queue.push(e, 2, 0, || d);
        }
        let mut take = |r: f64| {
            let mut out = Vec::new();
            queue.take_nearer(r, &mut out);
            let mut firsts: Vec<u32> = out.iter().map(|c| c.first).collect();
            firsts.sort_unstable();
            firsts
        };
        assert_eq!(take(9.2), vec![2, 4]);
        assert_eq!(take(100.0), vec![1, 3]);
        assert!(take(1000.0).is_empty());
    }
}
