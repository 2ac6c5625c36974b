//! The min-gap opening cut into tiles: a city across several tiles opens
//! to the same free space (area within 1e-5, the same passages open) as
//! untiled, and its cells have no slivers on the
//! tile borders. (Measured: 2e-6 with 8 m tiles, from the boolean
//! operations' grids, which differ with the extent of their input.)

use crate::common::block;
use citypvs::cells::narrow::open_free_space_with;
use citypvs::cells::tiles::Tiling;
use citypvs::cells::{CellParams, triangulate};
use citypvs::geometry::memo::ShapeMemo;
use citypvs::geometry::merge_blocks;
use citypvs::model::{Building, MultiPolygon, Polygon, multipolygon_area, point_in_multipolygon};
use glam::DVec2;

const MIN_GAP: f64 = 0.5;
const WIDE: f64 = 0.53;
const NARROW: f64 = 0.47;

/// Three rows of 10 m blocks around (256, 256), a corner of four coarse
/// tiles: between the blocks of a row vertical passages alternately 6%
/// wider and 6% narrower than the min gap, between the rows a wider and a
/// narrower horizontal passage. Returns the buildings and the middles of
/// the wide and of the narrow passages.
fn city() -> (Vec<Building>, Vec<DVec2>, Vec<DVec2>) {
    let mut buildings = Vec::new();
    let (mut wide, mut narrow) = (Vec::new(), Vec::new());
    let rows = [(240.0, 252.0), (252.0 + WIDE, 264.0 + WIDE)];
    let row3 = (rows[1].1 + NARROW, rows[1].1 + NARROW + 12.0);
    for (r, &(y0, y1)) in rows.iter().chain([row3].iter()).enumerate() {
        let mut x = 231.0;
        for i in 0..6 {
            buildings.push(block(&format!("b{r}-{i}"), x, y0, x + 10.0, y1, 10.0));
            let gap = if i % 2 == 0 { WIDE } else { NARROW };
            let mid = DVec2::new(x + 10.0 + 0.5 * gap, 0.5 * (y0 + y1));
            if i < 5 {
                if gap == WIDE {
                    wide.push(mid)
                } else {
                    narrow.push(mid)
                }
            }
            x += 10.0 + gap;
        }
    }
    wide.push(DVec2::new(256.0, 252.0 + 0.5 * WIDE));
    narrow.push(DVec2::new(256.0, rows[1].1 + 0.5 * NARROW));
    (buildings, wide, narrow)
}

/// The free space: a box around the city minus the blocks (which do not
/// touch, so they are its holes).
fn free_space(buildings: &[Building]) -> MultiPolygon {
    let (lo, hi) = (DVec2::new(221.0, 230.0), DVec2::new(310.0, 300.0));
    let holes = buildings
        .iter()
        .map(|b| {
            let mut h = b.footprint[0].exterior.clone();
            h.reverse();
            h
        })
        .collect();
    vec![Polygon {
        exterior: vec![lo, DVec2::new(hi.x, lo.y), hi, DVec2::new(lo.x, hi.y)],
        holes,
    }]
}

#[test]
fn tiled_opening_equals_the_untiled_one() {
    let (buildings, wide, narrow) = city();
    let free = free_space(&buildings);
    // One tile holds the whole city; then tiles of 8 m (borders every 8 m
    // across every passage), and the default tiling.
    let whole = open_free_space_with(
        &free,
        MIN_GAP,
        &Tiling::with(MIN_GAP, 4096.0, usize::MAX),
        &ShapeMemo::off(),
    )
    .free;
    let fine = open_free_space_with(
        &free,
        MIN_GAP,
        &Tiling::with(MIN_GAP, 8.0, 1),
        &ShapeMemo::off(),
    )
    .free;
    let default =
        open_free_space_with(&free, MIN_GAP, &Tiling::new(MIN_GAP), &ShapeMemo::off()).free;
    assert_eq!(Tiling::with(MIN_GAP, 8.0, 1).min_side, 8.0);
    let a = multipolygon_area(&whole);
    for (name, other) in [("default", &default), ("fine", &fine)] {
        let b = multipolygon_area(other);
        assert!(
            (a - b).abs() <= 1e-5 * a,
            "{name} tiling: {b} m2, untiled {a} m2"
        );
        for p in &wide {
            assert!(
                point_in_multipolygon(*p, other),
                "{name}: wide passage at {p} closed"
            );
        }
        for p in &narrow {
            assert!(
                !point_in_multipolygon(*p, other),
                "{name}: narrow passage at {p} open"
            );
        }
    }
    for p in &wide {
        assert!(
            point_in_multipolygon(*p, &whole),
            "untiled: wide passage at {p} closed"
        );
    }
}

#[test]
fn no_sliver_cells_on_tile_borders() {
    let (buildings, wide, _) = city();
    let params = CellParams {
        margin: 10.0,
        max_edge: 10.0,
        region: None,
        min_gap: MIN_GAP,
    };
    let cells = triangulate(&merge_blocks(&buildings), &params).unwrap();
    let mut near_border = 0;
    for t in &cells.triangles {
        let area2 = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
        let longest = (0..3)
            .map(|i| t[i].distance(t[(i + 1) % 3]))
            .fold(0.0, f64::max);
        let altitude = area2 / longest;
        // Cells that cross a border line or come within 1 m of one.
        let near = |c: fn(&DVec2) -> f64| {
            let lo = t.iter().map(c).fold(f64::INFINITY, f64::min);
            let hi = t.iter().map(c).fold(f64::NEG_INFINITY, f64::max);
            lo < 257.0 && hi > 255.0
        };
        let on_border = near(|v| v.x) || near(|v| v.y);
        near_border += usize::from(on_border);
        assert!(
            altitude >= 0.05,
            "cell {t:?} is {altitude} m thin (on a tile border: {on_border})"
        );
    }
    assert!(near_border > 10, "{near_border} cells by the tile borders");
    let has = |p: DVec2| {
        cells.triangles.iter().any(|t| {
            let s = |a: DVec2, b: DVec2| (b - a).perp_dot(p - a) >= 0.0;
            s(t[0], t[1]) && s(t[1], t[2]) && s(t[2], t[0])
        })
    };
    for p in &wide {
        assert!(has(*p), "no cell in the wide passage at {p}");
    }
}
