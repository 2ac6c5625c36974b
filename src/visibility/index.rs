//! Scene indexes built once per bake and shared by every sample: the shrunk
//! occluder edges in a bucket grid, each object's conservative pixel spans
//! on the global cull-map grid, and the object height pyramid used to reject
//! whole districts with one horizon test.

use glam::DVec2;

use crate::geometry::Occluder;
use crate::grid::{CellLists, UniformGrid};
use crate::model::{
    Building, Rect, cut_points, distance_to_segment, piece_count, polygon_edges, ring_crossings,
    ring_edges,
};

/// One edge (piece) of a shrunk occluder level, with the solid on its
/// left, as the index keeps it: its end points are read from
/// [`RingPoints`] ([`SceneIndex::edge_points`]), which holds every point
/// once per ring, so they are not stored here a second time.
#[derive(Clone, Copy, Debug)]
pub struct OccluderEdge {
    /// Height of the level in metres.
    pub height: f64,
    /// Index of the next edge along the same ring.
    pub next: u32,
    /// Position of this piece along its ring (0 for the ring's first piece).
    pub ring_pos: u32,
}

/// The pixel grid shared by every cull map: pixel (i, j) covers
/// `[i k, (i+1) k] x [j k, (j+1) k]` in local metres.
#[derive(Clone, Copy, Debug)]
pub struct PixelGrid {
    pub pixel: f64,
}

impl PixelGrid {
    /// Centre of pixel (i, j).
    pub fn centre(&self, i: i32, j: i32) -> DVec2 {
        DVec2::new((i as f64 + 0.5) * self.pixel, (j as f64 + 0.5) * self.pixel)
    }

    /// The pixel containing `p`.
    pub fn pixel_of(&self, p: DVec2) -> (i32, i32) {
        (
            (p.x / self.pixel).floor() as i32,
            (p.y / self.pixel).floor() as i32,
        )
    }
}

/// A run of pixels `i0..i1` in row `j`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    pub j: i32,
    pub i0: i32,
    pub i1: i32,
}

/// A PVS object as the visibility test sees it.
#[derive(Clone, Debug)]
pub struct ObjectRaster {
    pub height: f64,
    pub rect: Rect,
    /// The convex hull of the footprint (counter-clockwise; its vertices
    /// are footprint vertices, exact predicates): the horizon test's
    /// directions and nearest distance ([`super::horizon::object_distance`],
    /// [`super::horizon::RectView::of_object`]).
    pub hull: Vec<DVec2>,
    /// Every pixel the unshrunk footprint may overlap (a superset).
    pub spans: Vec<Span>,
}

/// A node of the object pyramid: the bounding rectangle and greatest height
/// of everything below it.
#[derive(Clone, Debug)]
pub struct PyramidNode {
    pub rect: Rect,
    pub max_height: f64,
    pub children: Vec<u32>,
    pub objects: Vec<u32>,
}

/// Everything the per-sample solver looks up.
pub struct SceneIndex {
    pub grid: PixelGrid,
    pub edges: Vec<OccluderEdge>,
    /// The chains' points in one flat list (see [`RingPoints`]).
    pub ring_points: RingPoints,
    /// The edge bucket grid (see [`bucket_grid`]).
    buckets: UniformGrid,
    /// Per bucket, the edges whose bounding box overlaps it.
    bucket_lists: CellLists,
    /// The edges whose first point `a` lies in each bucket (clamped to the
    /// grid), where the horizon's chains start and only there, are a
    /// stretch of the numbering: first those that start chains of stride 4
    /// (position on their ring a multiple of 4), then of stride 2, then
    /// the rest. Per bucket `b` and class `k` (0, 1, 2), the stretch of
    /// that class starts at entry `3 b + k`; the last entry is the number
    /// of edges.
    class_starts: Vec<u32>,
    /// Greatest occluder height among the edges starting in each bucket (0
    /// when none).
    bucket_heights: Vec<f64>,
    /// Per bucket and chain stride (1, 2, 4), the bounding rectangle of
    /// every chain the solver may start from the edges starting in the
    /// bucket; entry 3 is the union of the three.
    bucket_chain_rects: Vec<[Rect; 4]>,
    /// The bucket hierarchy: squares of 4 x 4 and of 16 x 16 buckets (see
    /// [`BucketNodes`]), tested by the sweep before their buckets.
    bucket_nodes: [BucketNodes; NODE_LEVELS],
    pub objects: Vec<ObjectRaster>,
    pub pyramid: Vec<PyramidNode>,
    /// Index of the root node of the pyramid (none when there are no objects).
    pub root: Option<u32>,
    /// Per pyramid node, its parent (`NO_PARENT` for the root).
    pub parent: Vec<u32>,
    /// Per object, the pyramid leaf that holds it.
    pub object_leaf: Vec<u32>,
}

/// The parent of the pyramid's root.
pub const NO_PARENT: u32 = u32::MAX;

const BUCKET_SIZE: f64 = 16.0;
const PYRAMID_LEAF: f64 = 32.0;
/// Most squares the bucket grid or a pyramid level may have: over a very
/// wide, sparse city the squares grow instead (an index only; any square
/// size gives the same visible sets).
const MAX_GRID_SQUARES: f64 = 4.0e6;

/// `step`, grown until a grid of such squares over `bounds` has at most
/// [`MAX_GRID_SQUARES`] squares.
fn grid_step(bounds: &Rect, step: f64) -> f64 {
    let squares = |s: f64| (bounds.width() / s + 1.0) * (bounds.height() / s + 1.0);
    let mut step = step;
    while squares(step) > MAX_GRID_SQUARES {
        step *= 2.0;
    }
    step
}

impl SceneIndex {
    pub fn build(buildings: &[Building], occluders: &[Occluder], pixel: f64) -> SceneIndex {
        let grid = PixelGrid { pixel };
        // The edges' points are read from `ring_points`, where each is kept
        // once, and the edges are kept without them.
        let (buckets, edges, ring_points, class_starts) = lay_out_edges(occluders);
        let starts_in = |b: usize| class_stretch(&class_starts, b, 3);
        let edge_range = |i: usize| {
            let (a, b) = ring_points.edge(i as u32);
            buckets.key_range(&Rect::of_points([&a, &b]))
        };
        let bucket_lists = CellLists::build(&buckets, edges.len(), edge_range);
        let bucket_heights: Vec<f64> = (0..buckets.len())
            .map(|b| {
                starts_in(b)
                    .map(|e| edges[e as usize].height)
                    .fold(0.0, f64::max)
            })
            .collect();
        let bucket_chain_rects: Vec<[Rect; 4]> = (0..buckets.len())
            .map(|b| {
                let mut rects = [Rect::EMPTY; 4];
                let mut all = Rect::EMPTY;
                for (level, rect) in rects.iter_mut().take(3).enumerate() {
                    let stride = 1u32 << level;
                    for e in starts_in(b) {
                        if !edges[e as usize].ring_pos.is_multiple_of(stride) {
                            continue;
                        }
                        // The chain of stride + 1 pieces starting here.
                        for &p in ring_points.chain(e, stride + 1) {
                            rect.include(p);
                        }
                    }
                    all = all.union(rect);
                }
                rects[3] = all;
                rects
            })
            .collect();
        let bucket_nodes = NODE_SHIFTS
            .map(|shift| BucketNodes::build(&buckets, shift, &bucket_heights, &bucket_chain_rects));
        let objects: Vec<ObjectRaster> = buildings
            .iter()
            .map(|b| rasterise_object(b, grid))
            .collect();
        let (pyramid, root) = build_pyramid(&objects);
        let mut parent = vec![NO_PARENT; pyramid.len()];
        let mut object_leaf = vec![0; objects.len()];
        for (n, node) in pyramid.iter().enumerate() {
            for &c in &node.children {
                parent[c as usize] = n as u32;
            }
            for &o in &node.objects {
                object_leaf[o as usize] = n as u32;
            }
        }
        SceneIndex {
            grid,
            edges,
            ring_points,
            buckets,
            bucket_lists,
            class_starts,
            bucket_heights,
            bucket_chain_rects,
            bucket_nodes,
            objects,
            pyramid,
            root,
            parent,
            object_leaf,
        }
    }

    /// How many points the index of `occluders` would hold (see
    /// [`MAX_INDEX_POINTS`]), counted without cutting or allocating.
    pub fn points_needed(occluders: &[Occluder]) -> u64 {
        occluder_rings(occluders)
            .map(|(_, ring)| {
                let pieces: u64 = ring_sides(ring).map(|(_, _, n)| n as u64).sum();
                if pieces == 0 {
                    0
                } else {
                    pieces + MAX_CHAIN_PIECES as u64
                }
            })
            .sum()
    }

    /// Side of an edge bucket in metres.
    pub fn bucket_size(&self) -> f64 {
        self.buckets.cell_size()
    }

    /// The largest Chebyshev ring (in buckets) around `v`'s bucket that
    /// still touches the bucket grid.
    pub fn max_bucket_ring(&self, v: DVec2) -> i64 {
        self.buckets.max_ring(v)
    }

    /// Call `f` with every bucket at Chebyshev distance exactly `ring` from
    /// the bucket containing `v`.
    pub fn buckets_in_ring(&self, v: DVec2, ring: i64, f: impl FnMut(usize)) {
        self.buckets.for_each_in_ring(v, ring, f);
    }

    /// The edges whose bounding box overlaps bucket `b`.
    pub fn bucket_edges(&self, b: usize) -> &[u32] {
        self.bucket_lists.get(b)
    }

    /// The edges whose first point lies in bucket `b` (each edge starts in
    /// exactly one bucket): those of stride 4, then of stride 2, then the
    /// rest, each class in the occluders' order.
    pub fn bucket_starts(&self, b: usize) -> std::ops::Range<u32> {
        class_stretch(&self.class_starts, b, 3)
    }

    /// The edges of [`SceneIndex::bucket_starts`] whose position on their
    /// ring is a multiple of `stride` (1, 2 or 4): a first stretch of them.
    pub fn bucket_starts_strided(&self, b: usize, stride: u32) -> std::ops::Range<u32> {
        let classes = match stride {
            4 => 1,
            2 => 2,
            _ => 3,
        };
        class_stretch(&self.class_starts, b, classes)
    }

    /// The greatest occluder height among the edges starting in bucket `b`.
    pub fn bucket_height(&self, b: usize) -> f64 {
        self.bucket_heights[b]
    }

    /// The bounding rectangle of the chains of `stride + 1` pieces that
    /// start at every `stride`-th piece (stride 1, 2 or 4) among the edges
    /// starting in bucket `b`; `None` for the union over the three strides.
    /// Empty when there are none.
    pub fn bucket_chain_rect(&self, b: usize, stride: Option<u32>) -> &Rect {
        let level = stride.map_or(3, |s| (s.trailing_zeros() as usize).min(2));
        &self.bucket_chain_rects[b][level]
    }

    /// Call `f` with the column, row and index of every bucket at
    /// Chebyshev distance exactly `ring` from the bucket containing `v`, in
    /// the order of [`SceneIndex::buckets_in_ring`].
    pub fn buckets_in_ring_keyed(&self, v: DVec2, ring: i64, f: impl FnMut(usize, usize, usize)) {
        self.buckets.for_each_in_ring_keyed(v, ring, f);
    }

    /// Level `level` (0: squares of 4 x 4 buckets, 1: of 16 x 16; see
    /// [`NODE_SHIFTS`]) of the
    /// bucket hierarchy.
    pub fn bucket_nodes(&self, level: usize) -> &BucketNodes {
        &self.bucket_nodes[level]
    }

    /// The bucket grid's columns and rows.
    pub fn bucket_dims(&self) -> (usize, usize) {
        (self.buckets.nx(), self.buckets.ny())
    }

    /// The (unclamped) column and row of the bucket holding `p`.
    pub fn bucket_cell_of(&self, p: DVec2) -> (i64, i64) {
        self.buckets.cell_of(p)
    }

    /// The index of the bucket in column `x`, row `y`.
    pub fn bucket_index(&self, x: usize, y: usize) -> usize {
        self.buckets.index((x, y))
    }

    /// How many buckets there are.
    pub fn bucket_count(&self) -> usize {
        self.buckets.len()
    }

    /// The column and row of bucket `b`.
    pub fn bucket_key(&self, b: usize) -> (usize, usize) {
        (b % self.buckets.nx(), b / self.buckets.nx())
    }

    /// The square bucket `b` covers.
    pub fn bucket_rect(&self, b: usize) -> Rect {
        self.buckets.cell_rect(b)
    }

    /// The first and last point of edge `e` (the solid on its left).
    #[inline]
    pub fn edge_points(&self, e: u32) -> (DVec2, DVec2) {
        self.ring_points.edge(e)
    }

    /// The first point of edge `e`.
    #[inline]
    pub fn edge_first_point(&self, e: u32) -> DVec2 {
        self.ring_points.first(e)
    }

    /// Call `f` with the index of every edge whose bucket overlaps `rect`
    /// (an edge may be reported more than once).
    pub fn edges_near(&self, rect: &Rect, mut f: impl FnMut(u32)) {
        if self.buckets.misses(rect) {
            return;
        }
        self.buckets.for_each_in_rect(rect, |b| {
            for &e in self.bucket_lists.get(b) {
                f(e);
            }
        });
    }
}

/// Side, as a power of two in buckets, of the nodes of each level of the
/// bucket hierarchy: 4 x 4 and 16 x 16 buckets.
pub const NODE_SHIFTS: [u32; NODE_LEVELS] = [2, 4];

/// How many levels the bucket hierarchy has.
pub const NODE_LEVELS: usize = 2;

/// How far each node's rectangle is grown beyond the union of its buckets'
/// chain rectangles, in metres: a margin far above the rounding of the
/// pseudo-angles, so every direction to a bucket's rectangle is computed
/// inside the node's bins (docs/DESIGN.md, "The bucket hierarchy").
const NODE_RECT_MARGIN: f64 = 1e-3;

/// One level of the bucket hierarchy: the squares of `1 << shift` by
/// `1 << shift` buckets (from the bucket grid's origin), each with the
/// union of every chain rectangle of its buckets (all three strides), grown
/// by `NODE_RECT_MARGIN`, and the greatest height of its buckets.
#[derive(Clone, Debug)]
pub struct BucketNodes {
    shift: u32,
    nx: usize,
    rects: Vec<Rect>,
    heights: Vec<f64>,
}

impl BucketNodes {
    fn build(
        buckets: &UniformGrid,
        shift: u32,
        heights: &[f64],
        chain_rects: &[[Rect; 4]],
    ) -> BucketNodes {
        let side = 1usize << shift;
        let nx = buckets.nx().div_ceil(side);
        let ny = buckets.ny().div_ceil(side);
        let mut rects = vec![Rect::EMPTY; nx * ny];
        let mut node_heights = vec![0.0f64; nx * ny];
        for b in 0..buckets.len() {
            let n = ((b / buckets.nx()) >> shift) * nx + ((b % buckets.nx()) >> shift);
            rects[n] = rects[n].union(&chain_rects[b][3]);
            node_heights[n] = node_heights[n].max(heights[b]);
        }
        for r in &mut rects {
            if !r.is_empty() {
                *r = r.grown(NODE_RECT_MARGIN);
            }
        }
        BucketNodes {
            shift,
            nx,
            rects,
            heights: node_heights,
        }
    }

    /// How many nodes the level has.
    pub fn len(&self) -> usize {
        self.rects.len()
    }

    /// Never true for a built index (a grid has at least one bucket).
    pub fn is_empty(&self) -> bool {
        self.rects.is_empty()
    }

    /// The node holding the bucket in column `x`, row `y`.
    pub fn node_of(&self, x: usize, y: usize) -> usize {
        (y >> self.shift) * self.nx + (x >> self.shift)
    }

    /// The node's grown chain rectangle (empty when no edge starts in it).
    pub fn rect(&self, n: usize) -> &Rect {
        &self.rects[n]
    }

    /// The greatest height of the node's buckets.
    pub fn height(&self, n: usize) -> f64 {
        self.heights[n]
    }
}

/// The edge bucket grid: [`BUCKET_SIZE`] squares (grown by [`grid_step`]
/// over a very wide city) from the multiple of the square size at or below
/// the lower left corner of `bounds` (the edges' bounding box), enough of
/// them that the box's far sides lie inside the grid.
fn bucket_grid(mut bounds: Rect) -> UniformGrid {
    if bounds.is_empty() {
        bounds = Rect {
            min: DVec2::ZERO,
            max: DVec2::ZERO,
        };
    }
    // Anchored in absolute local metres (the origin a multiple of the
    // bucket size), so a bucket covers the same square whatever else the
    // city holds. The horizon's chains do not depend on the grid at all
    // (see `chain_cell`); the grid only decides in which groups edges are
    // visited.
    let size = grid_step(&bounds, BUCKET_SIZE);
    let origin = (bounds.min / size).floor() * size;
    let nx = ((bounds.max.x - origin.x) / size).floor() as usize + 1;
    let ny = ((bounds.max.y - origin.y) / size).floor() as usize + 1;
    UniformGrid::square(origin, size, nx, ny)
}

/// Longest occluder edge piece: long walls are cut so that a short chain of
/// pieces lies within a narrow band of distances from any eye, which keeps
/// the horizon's distance ordering tight.
pub const MAX_EDGE_PIECE: f64 = 6.0;

/// The most pieces a horizon chain may hold: a chain starting at any piece
/// of a ring finds its points in one stretch of [`RingPoints`].
pub const MAX_CHAIN_PIECES: usize = 5;

/// Every ring's points in ring order (the first point of each piece), each
/// ring followed by its first [`MAX_CHAIN_PIECES`] points again, so the
/// points of a chain of up to that many pieces starting at any piece are
/// one slice: no walk along the pieces' `next` links and no copy per chain
/// (the edges themselves are in bucket order, so a ring's pieces are
/// scattered over the list). A piece's last point is the next piece's
/// first point exactly (both are the same cut point), so the slice holds
/// the very numbers the pieces hold.
pub struct RingPoints {
    points: Vec<DVec2>,
    /// Per edge, where its first point is in `points`.
    start: Vec<u32>,
}

impl RingPoints {
    /// The first and last point of edge `e`.
    #[inline]
    pub fn edge(&self, e: u32) -> (DVec2, DVec2) {
        let from = self.start[e as usize] as usize;
        (self.points[from], self.points[from + 1])
    }

    /// The first point of edge `e`.
    #[inline]
    pub fn first(&self, e: u32) -> DVec2 {
        self.points[self.start[e as usize] as usize]
    }

    /// The points of the chain of `pieces` pieces (at most
    /// [`MAX_CHAIN_PIECES`]) starting at edge `e`: its first point, then
    /// each piece's last point.
    #[inline]
    pub fn chain(&self, e: u32, pieces: u32) -> &[DVec2] {
        let from = self.start[e as usize] as usize;
        &self.points[from..=from + pieces as usize]
    }
}

/// Every ring of every occluder with the occluder's height, in the
/// occluders' order: the order the edges are numbered from before they are
/// put in bucket order.
fn occluder_rings(occluders: &[Occluder]) -> impl Iterator<Item = (f64, &[DVec2])> + '_ {
    occluders.iter().flat_map(|occ| {
        occ.shape.iter().flat_map(move |polygon| {
            std::iter::once(&polygon.exterior)
                .chain(polygon.holes.iter())
                .map(move |ring| (occ.height, ring.as_slice()))
        })
    })
}

/// Each side of a ring with the number of pieces of at most
/// [`MAX_EDGE_PIECE`] it is cut into.
fn ring_sides(ring: &[DVec2]) -> impl Iterator<Item = (DVec2, DVec2, usize)> + '_ {
    ring_edges(ring).map(|(a, b)| (a, b, piece_count(a, b, MAX_EDGE_PIECE)))
}

/// The first points of a ring's pieces in ring order (a piece's last
/// point is the next piece's first point, the ring's last piece ending at
/// the first).
fn piece_starts(ring: &[DVec2]) -> impl Iterator<Item = DVec2> + '_ {
    ring_sides(ring).flat_map(|(a, b, pieces)| cut_points(a, b, pieces).take(pieces))
}

/// The most points the occluder index may hold (each piece's first point,
/// and [`MAX_CHAIN_PIECES`] more per ring): its numbers are 32 bits wide,
/// and at about 40 bytes a piece this is some 80 GB of index already.
pub const MAX_INDEX_POINTS: u64 = 1 << 31;

/// The edges (pieces) of every occluder ring, numbered by the bucket that
/// holds their first point, within a bucket by the longest stride a chain
/// may start at them with ([`stride_class`]), and within that in the
/// occluders' order (a counting sort: the pieces keep the order in which
/// the rings give them, and the pieces of a ring mostly follow each
/// other), with `next` following the numbering; where each bucket's and
/// class's stretch starts (see `SceneIndex::class_starts`); and their
/// points ([`RingPoints`]): the rings in the order of their first pieces'
/// numbers. The sweep then reads each bucket's edges, a stride's first,
/// and their chains from one stretch of memory. Nothing else depends on the
/// numbering: the chains and their order within a bucket are the same, and
/// the near-field map draws the edges in an order fixed by their
/// coordinates.
///
/// The pieces are cut from the rings three times (for the bounds, the
/// counts and the placing) instead of being held in a list in the
/// occluders' order and then moved: each edge is written once, in its
/// place, and no second list of them is ever held.
fn lay_out_edges(occluders: &[Occluder]) -> (UniformGrid, Vec<OccluderEdge>, RingPoints, Vec<u32>) {
    // Every piece's last point is the first point of the next piece along
    // its ring, so the first points alone have the bounds of all the points.
    let mut bounds = Rect::EMPTY;
    for (_, ring) in occluder_rings(occluders) {
        for a in piece_starts(ring) {
            bounds.include(a);
        }
    }
    let buckets = bucket_grid(bounds);
    let bucket = |a: DVec2| buckets.index(buckets.key(a));
    let slot = |a: DVec2, ring_pos: u32| 3 * bucket(a) + stride_class(ring_pos);
    // Pieces per bucket and class; per ring, its pieces and its first
    // piece's bucket.
    let mut fill = vec![0u32; 3 * buckets.len() + 1];
    let mut rings: Vec<(u32, u32)> = Vec::new();
    let mut rings_from = vec![0u32; buckets.len() + 1];
    for (_, ring) in occluder_rings(occluders) {
        let mut pieces = 0u32;
        let mut head = 0;
        for a in piece_starts(ring) {
            if pieces == 0 {
                head = bucket(a);
            }
            fill[slot(a, pieces) + 1] += 1;
            pieces += 1;
        }
        if pieces > 0 {
            rings.push((pieces, head as u32));
            rings_from[head + 1] += 1;
        }
    }
    for k in 0..3 * buckets.len() {
        fill[k + 1] += fill[k];
    }
    for b in 0..buckets.len() {
        rings_from[b + 1] += rings_from[b];
    }
    let count = fill[3 * buckets.len()] as usize;
    // Where each ring's points go: rings by their first piece's bucket,
    // in the occluders' order within a bucket (the order of their first
    // pieces' numbers: a first piece is of class 0), each ring's points
    // followed by its first MAX_CHAIN_PIECES points again.
    let mut ring_order = vec![0u32; rings.len()];
    for (r, &(_, head)) in rings.iter().enumerate() {
        let slot = &mut rings_from[head as usize];
        ring_order[*slot as usize] = r as u32;
        *slot += 1;
    }
    drop(rings_from);
    let mut points_at = vec![0usize; rings.len()];
    let mut total = 0;
    for &r in &ring_order {
        points_at[r as usize] = total;
        total += rings[r as usize].0 as usize + MAX_CHAIN_PIECES;
    }
    drop(ring_order);
    let mut points = vec![DVec2::ZERO; total];
    let mut start = vec![0u32; count];
    let unset = OccluderEdge {
        height: 0.0,
        next: 0,
        ring_pos: 0,
    };
    let mut edges = vec![unset; count];
    let mut r = 0;
    for (height, ring) in occluder_rings(occluders) {
        let mut first = None;
        let mut previous: Option<usize> = None;
        let mut ring_pos = 0u32;
        for a in piece_starts(ring) {
            let next_free = &mut fill[slot(a, ring_pos)];
            let e = *next_free as usize;
            *next_free += 1;
            let at = points_at[r] + ring_pos as usize;
            points[at] = a;
            start[e] = at as u32;
            edges[e] = OccluderEdge {
                height,
                next: 0,
                ring_pos,
            };
            if let Some(p) = previous {
                edges[p].next = e as u32;
            }
            first.get_or_insert(e);
            previous = Some(e);
            ring_pos += 1;
        }
        // Close the ring: the last piece continues with the first, and
        // the points go on round the ring for chains starting near its end.
        if let (Some(first), Some(last)) = (first, previous) {
            edges[last].next = first as u32;
            let (at, pieces) = (points_at[r], ring_pos as usize);
            for k in 0..MAX_CHAIN_PIECES {
                points[at + pieces + k] = points[at + k % pieces];
            }
            r += 1;
        }
    }
    // Each bucket's and class's pieces now end where `fill` stands, which
    // is where the next ones start.
    fill.pop();
    fill.insert(0, 0);
    (buckets, edges, RingPoints { points, start }, fill)
}

/// The edges of bucket `b` in its first `classes` stride classes (see
/// `SceneIndex::class_starts`): a stretch of the numbering.
fn class_stretch(class_starts: &[u32], b: usize, classes: usize) -> std::ops::Range<u32> {
    class_starts[3 * b]..class_starts[3 * b + classes]
}

/// The longest stride a chain may start at a piece with, by the piece's
/// position on its ring, as a class: 0 for stride 4 (a multiple of 4), 1
/// for stride 2 (a multiple of 2), 2 for stride 1.
fn stride_class(ring_pos: u32) -> usize {
    match ring_pos {
        p if p.is_multiple_of(4) => 0,
        p if p.is_multiple_of(2) => 1,
        _ => 2,
    }
}

/// Every pixel whose centre lies inside the footprint or within half a
/// pixel diagonal of its boundary: a superset of the pixels the footprint
/// overlaps (conservative occludee rasterisation).
///
/// Row by row: the row's crossings with every ring are found once (the
/// very numbers [`crate::model::point_in_ring`] finds for each of the row's centres, so
/// "inside" is decided bit for bit as it would be), and only the sides that
/// reach within twice the reach of the row's centre line are measured
/// (a side farther away in y is farther than twice the reach from every
/// centre of the row, far beyond any rounding of the distance).
fn rasterise_object(building: &Building, grid: PixelGrid) -> ObjectRaster {
    let mut rect = Rect::EMPTY;
    for p in &building.footprint {
        for v in &p.exterior {
            rect.include(*v);
        }
    }
    let reach = grid.pixel * std::f64::consts::FRAC_1_SQRT_2 * (1.0 + 1e-9);
    let (i_lo, j_lo) = grid.pixel_of(rect.min - DVec2::splat(reach));
    let (i_hi, j_hi) = grid.pixel_of(rect.max + DVec2::splat(reach));
    let sides: Vec<(DVec2, DVec2)> = building.footprint.iter().flat_map(polygon_edges).collect();
    let mut near: Vec<(DVec2, DVec2)> = Vec::new();
    // Per polygon, the crossings of its exterior, then of each hole.
    let mut crossings: Vec<Vec<Vec<f64>>> = building
        .footprint
        .iter()
        .map(|p| vec![Vec::new(); 1 + p.holes.len()])
        .collect();
    let odd_beyond = |xs: &[f64], x: f64| xs.iter().filter(|&&c| x < c).count() % 2 == 1;
    let mut spans = Vec::new();
    for j in j_lo..=j_hi {
        let y = grid.centre(i_lo, j).y;
        near.clear();
        near.extend(
            sides.iter().copied().filter(|(a, b)| {
                a.y.min(b.y) - 2.0 * reach <= y && y <= a.y.max(b.y) + 2.0 * reach
            }),
        );
        for (polygon, rings) in building.footprint.iter().zip(&mut crossings) {
            for (ring, xs) in std::iter::once(&polygon.exterior)
                .chain(&polygon.holes)
                .zip(rings.iter_mut())
            {
                xs.clear();
                ring_crossings(ring, y, |x| xs.push(x));
            }
        }
        let inside_footprint = |x: f64| {
            crossings.iter().any(|rings| {
                odd_beyond(&rings[0], x) && !rings[1..].iter().any(|xs| odd_beyond(xs, x))
            })
        };
        let mut run: Option<i32> = None;
        for i in i_lo..=i_hi + 1 {
            let inside = i <= i_hi && {
                let c = grid.centre(i, j);
                inside_footprint(c.x)
                    || near
                        .iter()
                        .any(|&(a, b)| distance_to_segment(c, a, b) <= reach)
            };
            match (inside, run) {
                (true, None) => run = Some(i),
                (false, Some(i0)) => {
                    spans.push(Span { j, i0, i1: i });
                    run = None;
                }
                _ => {}
            }
        }
    }
    ObjectRaster {
        height: building.height,
        rect,
        hull: footprint_hull(building),
        spans,
    }
}

/// The convex hull of every exterior vertex of the footprint, found with
/// exact orientation predicates (`geo`'s robust kernel), so every footprint
/// point lies in it and its vertices are footprint vertices, bit for bit;
/// `geo` gives it counter-clockwise.
pub(crate) fn footprint_hull(building: &Building) -> Vec<DVec2> {
    use geo::ConvexHull;
    let points: Vec<geo::Point<f64>> = building
        .footprint
        .iter()
        .flat_map(|p| p.exterior.iter())
        .map(|v| geo::Point::new(v.x, v.y))
        .collect();
    let hull = geo::MultiPoint::new(points).convex_hull();
    let ring = &hull.exterior().0;
    // `geo` closes the ring: the last point repeats the first.
    let n = ring.len().saturating_sub(1);
    ring[..n].iter().map(|c| DVec2::new(c.x, c.y)).collect()
}

impl ObjectRaster {
    /// The distance the object is queued at and its horizon test takes its
    /// slope at, seen from `v`, and whether it is the hull's
    /// ([`super::horizon::object_distance`]).
    pub fn distance_from(&self, v: DVec2) -> (f64, bool) {
        super::horizon::object_distance(v, &self.hull, &self.rect)
    }

    /// The object's horizon test seen from `(v, eye)`, at the distance
    /// [`ObjectRaster::distance_from`] gave (`at`): by its hull, up to its
    /// height. The bake's test of an object outside the window, and the
    /// incremental bake's probe of it.
    pub fn view_from(&self, v: DVec2, eye: f64, at: (f64, bool)) -> super::horizon::RectView {
        super::horizon::RectView::of_object(v, eye, (&self.hull, &self.rect), self.height, at)
    }
}

fn build_pyramid(objects: &[ObjectRaster]) -> (Vec<PyramidNode>, Option<u32>) {
    if objects.is_empty() {
        return (Vec::new(), None);
    }
    let mut bounds = Rect::EMPTY;
    for o in objects {
        bounds = bounds.union(&o.rect);
    }
    let leaf = grid_step(&bounds, PYRAMID_LEAF);
    let leaves = UniformGrid::square(
        bounds.min,
        leaf,
        (bounds.width() / leaf).floor() as usize + 1,
        (bounds.height() / leaf).floor() as usize + 1,
    );
    let (mut nx, mut ny) = (leaves.nx(), leaves.ny());
    let mut level: Vec<Option<PyramidNode>> = vec![None; leaves.len()];
    for (idx, o) in objects.iter().enumerate() {
        let c = (o.rect.min + o.rect.max) * 0.5;
        let node = level[leaves.index(leaves.key(c))].get_or_insert_with(|| PyramidNode {
            rect: Rect::EMPTY,
            max_height: 0.0,
            children: Vec::new(),
            objects: Vec::new(),
        });
        node.rect = node.rect.union(&o.rect);
        node.max_height = node.max_height.max(o.height);
        node.objects.push(idx as u32);
    }
    let mut nodes: Vec<PyramidNode> = Vec::new();
    // Indices of the current level's nodes in `nodes`.
    let mut current: Vec<Option<u32>> = level
        .into_iter()
        .map(|n| {
            n.map(|n| {
                nodes.push(n);
                nodes.len() as u32 - 1
            })
        })
        .collect();
    while nx > 1 || ny > 1 {
        let (px, py) = (nx.div_ceil(2), ny.div_ceil(2));
        let mut parents: Vec<Option<u32>> = vec![None; px * py];
        for y in 0..py {
            for x in 0..px {
                let mut node = PyramidNode {
                    rect: Rect::EMPTY,
                    max_height: 0.0,
                    children: Vec::new(),
                    objects: Vec::new(),
                };
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (cx, cy) = (2 * x + dx, 2 * y + dy);
                    if cx < nx
                        && cy < ny
                        && let Some(c) = current[cy * nx + cx]
                    {
                        let child = &nodes[c as usize];
                        node.rect = node.rect.union(&child.rect);
                        node.max_height = node.max_height.max(child.max_height);
                        node.children.push(c);
                    }
                }
                if !node.children.is_empty() {
                    nodes.push(node);
                    parents[y * px + x] = Some(nodes.len() as u32 - 1);
                }
            }
        }
        current = parents;
        nx = px;
        ny = py;
    }
    let root = current[0];
    (nodes, root)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Polygon;

    fn ring(points: &[(f64, f64)]) -> Vec<DVec2> {
        points.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    /// Occluders with long walls (cut into pieces), a courtyard and rings
    /// in several buckets.
    fn occluders() -> Vec<Occluder> {
        let block = Polygon {
            exterior: ring(&[(0.0, 0.0), (70.0, 0.0), (70.0, 40.0), (0.0, 40.0)]),
            holes: vec![ring(&[
                (10.0, 10.0),
                (10.0, 30.0),
                (60.0, 30.0),
                (60.0, 10.0),
            ])],
        };
        let tower = Polygon {
            exterior: ring(&[(100.3, -20.7), (105.1, -20.7), (105.1, 3.9)]),
            holes: vec![],
        };
        [(block, 12.0), (tower, 40.0)]
            .into_iter()
            .enumerate()
            .map(|(i, (p, height))| Occluder {
                block: i,
                level: 0,
                height,
                shape: vec![p],
            })
            .collect()
    }

    proptest::proptest! {
        /// The row-by-row rasteriser marks exactly the pixels whose centre
        /// lies in the footprint or within the reach of a side of it, each
        /// decided alone: random star-shaped polygons (so they need not be
        /// convex), some with a hole, off the grid's origin.
        #[test]
        fn an_object_s_spans_are_the_pixels_in_or_near_its_footprint(
            radii in proptest::collection::vec(2.0f64..30.0, 3..12),
            hole in proptest::option::of(0.2f64..0.6),
            second in proptest::bool::ANY,
            centre in (-500.0f64..500.0, -500.0f64..500.0),
            pixel in 0.5f64..2.5,
        ) {
            let star = |c: DVec2, scale: f64, clockwise: bool| -> Vec<DVec2> {
                let n = radii.len();
                (0..n)
                    .map(|k| {
                        let k = if clockwise { n - 1 - k } else { k };
                        let turn = std::f64::consts::TAU * k as f64 / n as f64;
                        c + DVec2::new(turn.cos(), turn.sin()) * radii[k] * scale
                    })
                    .collect()
            };
            let c = DVec2::new(centre.0, centre.1);
            let mut footprint = vec![Polygon {
                exterior: star(c, 1.0, false),
                holes: hole.map(|h| star(c, h, true)).into_iter().collect(),
            }];
            if second {
                footprint.push(Polygon {
                    exterior: star(c + DVec2::new(45.0, 7.0), 0.5, false),
                    holes: vec![],
                });
            }
            let building = Building {
                id: "b".into(),
                footprint,
                height: 10.0,
                occludes: true,
            };
            let grid = PixelGrid { pixel };
            let raster = rasterise_object(&building, grid);
            let reach = pixel * std::f64::consts::FRAC_1_SQRT_2 * (1.0 + 1e-9);
            let marked = |i: i32, j: i32| {
                let c = grid.centre(i, j);
                crate::model::point_in_multipolygon(c, &building.footprint)
                    || building
                        .footprint
                        .iter()
                        .flat_map(polygon_edges)
                        .any(|(a, b)| distance_to_segment(c, a, b) <= reach)
            };
            let (lo, _) = grid.pixel_of(raster.rect.min - DVec2::splat(2.0 * reach));
            let (hi, _) = grid.pixel_of(raster.rect.max + DVec2::splat(2.0 * reach));
            let (_, j_lo) = grid.pixel_of(raster.rect.min - DVec2::splat(2.0 * reach));
            let (_, j_hi) = grid.pixel_of(raster.rect.max + DVec2::splat(2.0 * reach));
            for j in j_lo..=j_hi {
                for i in lo..=hi {
                    let in_span = raster
                        .spans
                        .iter()
                        .any(|s| s.j == j && s.i0 <= i && i < s.i1);
                    proptest::prop_assert_eq!(in_span, marked(i, j), "pixel ({}, {})", i, j);
                }
            }
        }
    }

    #[test]
    fn the_index_reads_each_edge_s_points_from_its_ring() {
        let occluders = occluders();
        let index = SceneIndex::build(&[], &occluders, 1.0);
        // Every piece is read back exactly, with its height, once.
        let key = |a: DVec2, b: DVec2, h: f64| [a.x, a.y, b.x, b.y, h].map(f64::to_bits);
        // Each piece's own two points, cut from the occluders' rings here.
        let mut want: Vec<_> = Vec::new();
        for o in &occluders {
            for polygon in &o.shape {
                for ring in std::iter::once(&polygon.exterior).chain(&polygon.holes) {
                    for i in 0..ring.len() {
                        let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                        let cuts: Vec<DVec2> =
                            cut_points(a, b, piece_count(a, b, MAX_EDGE_PIECE)).collect();
                        for w in cuts.windows(2) {
                            want.push(key(w[0], w[1], o.height));
                        }
                    }
                }
            }
        }
        assert_eq!(want.len(), index.edges.len());
        let mut got: Vec<_> = (0..index.edges.len() as u32)
            .map(|e| {
                let (a, b) = index.edge_points(e);
                assert_eq!(a, index.edge_first_point(e));
                key(a, b, index.edges[e as usize].height)
            })
            .collect();
        want.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, want);
        // The edges are numbered by the bucket of their first point, and
        // each bucket's list of starts holds exactly its edges.
        let bucket_of = |e: u32| {
            let buckets = &index.buckets;
            buckets.index(buckets.key(index.edge_first_point(e)))
        };
        let numbered: Vec<usize> = (0..index.edges.len() as u32).map(bucket_of).collect();
        assert!(numbered.is_sorted());
        assert!(numbered.windows(2).any(|w| w[0] != w[1]));
        for b in 0..index.buckets.len() {
            let listed: Vec<u32> = index.bucket_starts(b).collect();
            let class = |e: u32| stride_class(index.edges[e as usize].ring_pos);
            // Those of stride 4 first, then 2, then 1 (the strided lists'
            // contents are tested in tests/bake/skip_hidden.rs).
            assert!(listed.iter().map(|&e| class(e)).is_sorted());
            let want: Vec<u32> = (0..index.edges.len() as u32)
                .filter(|&e| bucket_of(e) == b)
                .collect();
            assert_eq!(listed, want);
        }
        // An edge ends exactly where the next one along its ring starts,
        // and a chain's slice is the edges' points in ring order.
        for e in 0..index.edges.len() as u32 {
            let next = index.edges[e as usize].next;
            assert_eq!(index.edge_points(e).1, index.edge_points(next).0);
            let chain = index.ring_points.chain(e, MAX_CHAIN_PIECES as u32);
            let mut cur = e;
            for w in chain.windows(2) {
                assert_eq!((w[0], w[1]), index.edge_points(cur));
                cur = index.edges[cur as usize].next;
            }
        }
    }
}
