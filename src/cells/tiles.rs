//! Tiles for the min-gap opening (docs/geometry.md section 4, "Tiles"): the
//! opening is local, so the free space is cut into square tiles fixed in
//! the local frame (multiples of a power-of-two side from the origin), each
//! tile is opened and cleaned with a margin of the free space around it,
//! cut back to the tile and snapped to its border lines, and the pieces are
//! merged into one free space. Peak memory is that of the few tiles in
//! flight plus the result, not that of the whole city's swept polygons.
//!
//! Owns the choice of tiles (a quadtree split of the coarse tiles until a
//! tile holds at most [`TILE_EDGES`] outline edges), cutting the free space
//! to a tile, and the stitch of the tiles' results.

use std::collections::BTreeMap;

use geo::BooleanOps;
use glam::DVec2;
use rayon::prelude::*;

use crate::geometry::convert::{multipolygon_from_geo, multipolygon_to_geo};
use crate::geometry::memo::{MemoKey, ShapeMemo};
use crate::model::{MultiPolygon, Polygon, Ring};

/// Most outline edges of the free space (within a tile grown by its margin)
/// a tile may hold before it is split in four, unless it is already at the
/// smallest side. The tile's opening holds one swept polygon of at most 18
/// vertices per edge (twice, erosion and dilation).
pub const TILE_EDGES: usize = 1500;

/// Side of the coarsest tiles in metres (a power of two).
pub const TOP_TILE: f64 = 256.0;

/// Most coarse tiles over the free space's extent (the coarse side doubles
/// until they fit): 65,536, a city of 65 km square at the default side.
pub const MAX_TOP_TILES: f64 = 65536.0;

/// The margin around a tile, in units of min_gap: the opening at a point
/// depends only on the free space within 1.02 min_gap + 2 mm of it, and the
/// clean-up looks at most 1.8 min_gap beyond a short edge and moves the
/// outline at most 1.6 min_gap; the rest is slack for chains of clean-ups.
pub const MARGIN_GAPS: f64 = 8.0;

/// Border vertices closer than this (metres) along a tile border are made
/// one: the same point computed in two tiles.
const SNAP: f64 = 1e-6;

/// A square tile of the local frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    pub min: DVec2,
    pub side: f64,
}

impl Tile {
    pub fn max(&self) -> DVec2 {
        self.min + DVec2::splat(self.side)
    }
}

/// How a city is tiled for a given min gap.
#[derive(Clone, Copy, Debug)]
pub struct Tiling {
    /// Tiles are grown by this before their free space is opened (metres).
    pub margin: f64,
    /// The smallest tile side; every tile border lies on a multiple of it.
    pub min_side: f64,
    /// The coarsest tile side.
    pub top_side: f64,
    /// The most edges of a tile before it is split.
    pub max_edges: usize,
}

impl Tiling {
    pub fn new(min_gap: f64) -> Tiling {
        Tiling::with(min_gap, TOP_TILE, TILE_EDGES)
    }

    /// A tiling with another coarse side (rounded up to a power of two) and
    /// edge budget, for tests.
    pub fn with(min_gap: f64, top: f64, max_edges: usize) -> Tiling {
        let margin = MARGIN_GAPS * min_gap;
        let min_side = (2.0 * margin).max(1.0).log2().ceil().exp2();
        let top_side = top.max(min_side).log2().ceil().exp2();
        Tiling {
            margin,
            min_side,
            top_side,
            max_edges: max_edges.max(1),
        }
    }
}

type Bounds = (DVec2, DVec2);

fn ring_bounds(ring: &[DVec2]) -> Bounds {
    ring.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    )
}

fn overlaps(a: Bounds, b: Bounds) -> bool {
    a.0.x <= b.1.x && b.0.x <= a.1.x && a.0.y <= b.1.y && b.0.y <= a.1.y
}

fn grown(tile: &Tile, margin: f64) -> Bounds {
    (
        tile.min - DVec2::splat(margin),
        tile.max() + DVec2::splat(margin),
    )
}

/// The tiles covering `free`, in a deterministic order: the coarse tiles
/// row by row, each split into quadrants (recursively, in the order SW, SE,
/// NW, NE) while it holds more than `max_edges` edges within its margin.
/// Which tiles cover a place depends only on the free space within the
/// coarse tile there (grown by the margin).
pub fn tiles(free: &MultiPolygon, tiling: &Tiling) -> Vec<Tile> {
    let edges: Vec<Bounds> = free
        .iter()
        .flat_map(|p| std::iter::once(&p.exterior).chain(p.holes.iter()))
        .flat_map(|ring| {
            (0..ring.len()).map(move |i| {
                let (a, b) = (ring[i], ring[(i + 1) % ring.len()]);
                (a.min(b), a.max(b))
            })
        })
        .collect();
    let Some(all) = free
        .iter()
        .map(|p| ring_bounds(&p.exterior))
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    else {
        return Vec::new();
    };
    // Over a very wide extent (reachable only through the library: the
    // readers refuse cities wider than 100 km) the coarse tiles grow, so
    // that their number stays bounded; the splitting below still refines
    // them wherever the outline is dense.
    let mut s = tiling.top_side;
    let count = |s: f64| ((all.1.x - all.0.x) / s + 2.0) * ((all.1.y - all.0.y) / s + 2.0);
    for _ in 0..2100 {
        if count(s) <= MAX_TOP_TILES {
            break;
        }
        s *= 2.0;
    }
    if count(s).is_nan() || count(s) > MAX_TOP_TILES {
        return Vec::new();
    }
    let (x0, x1) = ((all.0.x / s).floor() as i64, (all.1.x / s).floor() as i64);
    let (y0, y1) = ((all.0.y / s).floor() as i64, (all.1.y / s).floor() as i64);
    // The edges by coarse row (each under every row whose grown tiles it
    // may overlap, in ascending order), so a tile looks only at its row's.
    let rows = (y1 - y0 + 1) as usize;
    let mut by_row: Vec<Vec<u32>> = vec![Vec::new(); rows];
    for (i, e) in edges.iter().enumerate() {
        let lo = (((e.0.y - tiling.margin) / s).floor() as i64 - 1).clamp(y0, y1);
        let hi = (((e.1.y + tiling.margin) / s).floor() as i64 + 1).clamp(y0, y1);
        for r in lo..=hi {
            by_row[(r - y0) as usize].push(i as u32);
        }
    }
    let mut out = Vec::new();
    for iy in y0..=y1 {
        let row = &by_row[(iy - y0) as usize];
        for ix in x0..=x1 {
            let tile = Tile {
                min: DVec2::new(ix as f64 * s, iy as f64 * s),
                side: s,
            };
            let g = grown(&tile, tiling.margin);
            if !overlaps(g, all) {
                continue;
            }
            let mine: Vec<u32> = row
                .iter()
                .copied()
                .filter(|&i| overlaps(edges[i as usize], g))
                .collect();
            split(tile, &mine, &edges, tiling, &mut out);
        }
    }
    out
}

fn split(tile: Tile, mine: &[u32], edges: &[Bounds], tiling: &Tiling, out: &mut Vec<Tile>) {
    if mine.len() <= tiling.max_edges || tile.side <= tiling.min_side {
        out.push(tile);
        return;
    }
    let h = 0.5 * tile.side;
    for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
        let sub = Tile {
            min: tile.min + DVec2::new(dx * h, dy * h),
            side: h,
        };
        let g = grown(&sub, tiling.margin);
        let sub_mine: Vec<u32> = mine
            .iter()
            .copied()
            .filter(|&i| overlaps(edges[i as usize], g))
            .collect();
        split(sub, &sub_mine, edges, tiling, out);
    }
}

fn rect(lo: DVec2, hi: DVec2) -> geo::Polygon<f64> {
    geo::Polygon::new(
        vec![
            geo::Coord { x: lo.x, y: lo.y },
            geo::Coord { x: hi.x, y: lo.y },
            geo::Coord { x: hi.x, y: hi.y },
            geo::Coord { x: lo.x, y: hi.y },
        ]
        .into(),
        Vec::new(),
    )
}

/// The free space within the box `b`: every polygon and hole whose bounds
/// meet the box (a ring whose bounds miss the box neither meets nor holds
/// it), cut to the box.
pub fn cut_to(free: &MultiPolygon, bounds: &[(Bounds, Vec<Bounds>)], b: Bounds) -> MultiPolygon {
    let mut near: MultiPolygon = Vec::new();
    for (p, (eb, hbs)) in free.iter().zip(bounds) {
        if !overlaps(*eb, b) {
            continue;
        }
        let holes: Vec<Ring> = p
            .holes
            .iter()
            .zip(hbs)
            .filter(|(_, hb)| overlaps(**hb, b))
            .map(|(h, _)| h.clone())
            .collect();
        near.push(Polygon {
            exterior: p.exterior.clone(),
            holes,
        });
    }
    if near.is_empty() {
        return near;
    }
    let cut =
        multipolygon_to_geo(&near).intersection(&geo::MultiPolygon::new(vec![rect(b.0, b.1)]));
    multipolygon_from_geo(&cut, 0.0)
}

/// The bounds of every exterior and hole of `free`.
pub fn all_bounds(free: &MultiPolygon) -> Vec<(Bounds, Vec<Bounds>)> {
    free.iter()
        .map(|p| {
            (
                ring_bounds(&p.exterior),
                p.holes.iter().map(|h| ring_bounds(h)).collect(),
            )
        })
        .collect()
}

/// Run `open` (the opening and clean-up of a piece of free space) on every
/// tile's free space grown by the margin, cut each result back to its tile
/// and merge the pieces. Tiles run in parallel under rayon; the result does
/// not depend on the number of threads (pieces are merged in tile order).
///
/// A tile's result depends only on its piece of free space, the tile, the
/// margin and what `open` does, which `open_key` names (it starts the key
/// of the tile's result in `memo`: the step and its numbers).
pub fn open_tiled(
    free: &MultiPolygon,
    tiling: &Tiling,
    memo: &ShapeMemo,
    open_key: impl Fn() -> MemoKey + Sync,
    open: impl Fn(&MultiPolygon) -> MultiPolygon + Sync,
) -> MultiPolygon {
    let tiles = tiles(free, tiling);
    let bounds = all_bounds(free);
    let pieces: Vec<MultiPolygon> = tiles
        .par_iter()
        .map(|tile| {
            let piece = cut_to(free, &bounds, grown(tile, tiling.margin));
            if piece.is_empty() {
                return Vec::new();
            }
            let key = || {
                open_key()
                    .number(tile.min.x)
                    .number(tile.min.y)
                    .number(tile.side)
                    .number(tiling.margin)
                    .shape(&piece)
                    .finish()
            };
            memo.shape(key, || {
                let opened = open(&piece);
                if opened.is_empty() {
                    return Vec::new();
                }
                let cut = multipolygon_to_geo(&opened)
                    .intersection(&geo::MultiPolygon::new(vec![rect(tile.min, tile.max())]));
                let mut cut = multipolygon_from_geo(&cut, 0.0);
                snap_to_border(&mut cut, tile);
                cut
            })
        })
        .collect();
    stitch(pieces, tiling.min_side)
}

/// Put vertices within [`SNAP`] of the tile's border lines exactly on them.
fn snap_to_border(mp: &mut MultiPolygon, tile: &Tile) {
    let (lo, hi) = (tile.min, tile.max());
    let snap = |v: &mut f64, a: f64, b: f64| {
        if (*v - a).abs() <= SNAP {
            *v = a;
        } else if (*v - b).abs() <= SNAP {
            *v = b;
        }
    };
    for p in mp.iter_mut() {
        for ring in std::iter::once(&mut p.exterior).chain(p.holes.iter_mut()) {
            for v in ring.iter_mut() {
                snap(&mut v.x, lo.x, hi.x);
                snap(&mut v.y, lo.y, hi.y);
            }
        }
    }
}

/// Whether `v` is an exact multiple of `side`.
fn on_grid(v: f64, side: f64) -> bool {
    (v / side).round() * side == v
}

/// Merge the tiles' pieces: vertices on a tile border line that lie within
/// `SNAP` of each other along it (the same point computed in two tiles)
/// are made exactly one (a tile corner if there is one among them, else the
/// lowest), so that the two sides of a border share their border vertices
/// and the merge dissolves the border without leaving slivers.
pub fn stitch(mut pieces: Vec<MultiPolygon>, min_side: f64) -> MultiPolygon {
    // (vertical line?, line coordinate bits) -> [(along, piece, polygon, ring, vertex)]
    type At = (f64, u32, u32, u32, u32);
    let mut lines: BTreeMap<(bool, i64), Vec<At>> = BTreeMap::new();
    for (pi, mp) in pieces.iter().enumerate() {
        for (qi, p) in mp.iter().enumerate() {
            for (ri, ring) in std::iter::once(&p.exterior)
                .chain(p.holes.iter())
                .enumerate()
            {
                for (vi, v) in ring.iter().enumerate() {
                    let at = (pi as u32, qi as u32, ri as u32, vi as u32);
                    if on_grid(v.x, min_side) {
                        let key = (true, (v.x / min_side).round() as i64);
                        lines
                            .entry(key)
                            .or_default()
                            .push((v.y, at.0, at.1, at.2, at.3));
                    }
                    if on_grid(v.y, min_side) {
                        let key = (false, (v.y / min_side).round() as i64);
                        lines
                            .entry(key)
                            .or_default()
                            .push((v.x, at.0, at.1, at.2, at.3));
                    }
                }
            }
        }
    }
    for ((vertical, _), mut list) in lines {
        list.sort_by(|a, b| {
            a.0.total_cmp(&b.0)
                .then((a.1, a.2, a.3, a.4).cmp(&(b.1, b.2, b.3, b.4)))
        });
        let mut start = 0;
        while start < list.len() {
            let mut end = start + 1;
            while end < list.len() && list[end].0 - list[end - 1].0 <= SNAP {
                end += 1;
            }
            let group = &list[start..end];
            let value = group
                .iter()
                .map(|g| g.0)
                .find(|&v| on_grid(v, min_side))
                .unwrap_or(group[0].0);
            for &(_, pi, qi, ri, vi) in group {
                let p = &mut pieces[pi as usize][qi as usize];
                let ring = if ri == 0 {
                    &mut p.exterior
                } else {
                    &mut p.holes[ri as usize - 1]
                };
                let v = &mut ring[vi as usize];
                if vertical {
                    v.y = value;
                } else {
                    v.x = value;
                }
            }
            start = end;
        }
    }
    let all: MultiPolygon = pieces.into_iter().flatten().collect();
    if all.is_empty() {
        return all;
    }
    let merged = geo::unary_union(&multipolygon_to_geo(&all).0);
    let mut merged = multipolygon_from_geo(&merged, 0.0);
    for p in merged.iter_mut() {
        for ring in std::iter::once(&mut p.exterior).chain(p.holes.iter_mut()) {
            drop_straight_vertices(ring);
        }
    }
    merged
}

/// Vertices within [`SNAP`] of the segment joining their neighbours (where
/// a tile border crossed a straight edge) are dropped: the outline moves by
/// at most that much, far within the clearance.
fn drop_straight_vertices(ring: &mut Ring) {
    let mut out: Ring = Vec::with_capacity(ring.len());
    for i in 0..ring.len() {
        let v = ring[i];
        let next = ring[(i + 1) % ring.len()];
        if let Some(&prev) = out.last()
            && out.len() + (ring.len() - i) > 3
            && crate::model::distance_to_segment(v, prev, next) <= SNAP
        {
            continue;
        }
        out.push(v);
    }
    // The first vertex against the last kept and the second.
    if out.len() > 3
        && crate::model::distance_to_segment(out[0], out[out.len() - 1], out[1]) <= SNAP
    {
        out.remove(0);
    }
    *ring = out;
}
