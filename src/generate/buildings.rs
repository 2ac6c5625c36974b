//! Filling one block of the street plan with buildings, in the grid frame.
//!
//! Four kinds of block: perimeter rows of wall-sharing buildings around an
//! open inner yard, ring buildings with a courtyard hole, free-standing houses
//! on lots along the streets, and free-standing towers on a plaza. Every
//! coordinate that two buildings share is computed once and reused, so shared
//! walls have identical end points (no T-junctions) and never overlap.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::Kind;
use super::layout::{GridRect, cuts};

/// Widths of row buildings along the street, metres.
const ROW_WIDTH: (f64, f64) = (8.0, 25.0);
/// Depth of a row from the street, and of a courtyard ring, metres.
const ROW_DEPTH: (f64, f64) = (10.0, 20.0);
const COURTYARD_DEPTH: (f64, f64) = (10.0, 12.0);
/// Chance that a narrow row building (not at either end of its row) is left out, making a
/// passage into the yard, and the widest building that may be left out.
const PASSAGE_CHANCE: f64 = 0.15;
const PASSAGE_MAX_WIDTH: f64 = 12.0;
/// Typical width of a house lot along the street, and the house inside its lot, metres.
const LOT_WIDTH: f64 = 22.0;
const HOUSE_WIDTH: (f64, f64) = (8.0, 14.0);
const HOUSE_DEPTH: (f64, f64) = (8.0, 12.0);
const HOUSE_SETBACK: (f64, f64) = (3.0, 6.0);
/// Tower footprint side, metres, and height range.
const TOWER_SIDE: (f64, f64) = (18.0, 30.0);
pub const TOWER_HEIGHT: (f64, f64) = (40.0, 120.0);
/// Height range of everything that is not a tower.
pub const LOW_HEIGHT: (f64, f64) = (6.0, 30.0);

/// A building in the grid frame: an axis-aligned rectangle, possibly with a
/// rectangular courtyard hole.
#[derive(Clone, Debug, PartialEq)]
pub struct GridBuilding {
    pub kind: Kind,
    pub outer: GridRect,
    pub hole: Option<GridRect>,
    pub height: f64,
}

/// The kinds of block, chosen per block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BlockKind {
    Rows,
    Courtyards,
    Houses,
    Towers,
}

fn choose_block_kind(rng: &mut ChaCha8Rng) -> BlockKind {
    let x: f64 = rng.random();
    if x < 0.55 {
        BlockKind::Rows
    } else if x < 0.72 {
        BlockKind::Courtyards
    } else if x < 0.95 {
        BlockKind::Houses
    } else {
        BlockKind::Towers
    }
}

/// The buildings of one block (in a fixed order).
pub fn fill_block(rng: &mut ChaCha8Rng, rect: GridRect) -> Vec<GridBuilding> {
    match choose_block_kind(rng) {
        BlockKind::Rows => rows(rng, rect),
        BlockKind::Courtyards => courtyards(rng, rect),
        BlockKind::Houses => houses(rng, rect),
        BlockKind::Towers => towers(rng, rect),
    }
}

fn rect(u0: f64, v0: f64, u1: f64, v1: f64) -> GridRect {
    GridRect { u0, v0, u1, v1 }
}

/// Height of an ordinary building: whole storeys of 3 m plus a roof, in range.
fn low_height(rng: &mut ChaCha8Rng, storeys: (u32, u32)) -> f64 {
    let storeys = rng.random_range(storeys.0..=storeys.1) as f64;
    let h = storeys * 3.0 + rng.random_range(0.0..2.5);
    (h * 10.0).round() / 10.0
}

/// Perimeter rows around an open inner yard. Each side has its own depth.
/// The south and north rows run the full block width, with corner buildings
/// exactly as wide as the west and east rows are deep; the west and east rows
/// fit between them.
fn rows(rng: &mut ChaCha8Rng, b: GridRect) -> Vec<GridBuilding> {
    let mut depth = || rng.random_range(ROW_DEPTH.0..=ROW_DEPTH.1);
    let (ds, dn, dw, de) = (depth(), depth(), depth(), depth());
    // The inner yard's corners, shared by the four rows.
    let (iu0, iu1, iv0, iv1) = (b.u0 + dw, b.u1 - de, b.v0 + ds, b.v1 - dn);
    let storeys = if rng.random_bool(0.3) { (4, 9) } else { (2, 6) };
    let mut out = Vec::new();
    let mut push_row = |rng: &mut ChaCha8Rng, cuts: &[f64], make: &dyn Fn(f64, f64) -> GridRect| {
        let last = cuts.len() - 2;
        for (i, pair) in cuts.windows(2).enumerate() {
            let row_end = i == 0 || i == last;
            let narrow = pair[1] - pair[0] <= PASSAGE_MAX_WIDTH;
            if !row_end && narrow && rng.random_bool(PASSAGE_CHANCE) {
                continue;
            }
            out.push(GridBuilding {
                kind: Kind::Row,
                outer: make(pair[0], pair[1]),
                hole: None,
                height: low_height(rng, storeys),
            });
        }
    };
    // South and north: corner, middle cuts, corner.
    for (v0, v1) in [(b.v0, iv0), (iv1, b.v1)] {
        let mut c = vec![b.u0];
        c.extend(cuts(rng, iu0, iu1, ROW_WIDTH));
        c.push(b.u1);
        push_row(rng, &c, &|a, z| rect(a, v0, z, v1));
    }
    // West and east, between the south and north rows.
    for (u0, u1) in [(b.u0, iu0), (iu1, b.u1)] {
        let c = cuts(rng, iv0, iv1, ROW_WIDTH);
        push_row(rng, &c, &|a, z| rect(u0, a, u1, z));
    }
    out
}

/// One ring building with a courtyard, or two side by side sharing a wall.
fn courtyards(rng: &mut ChaCha8Rng, b: GridRect) -> Vec<GridBuilding> {
    let d = rng.random_range(COURTYARD_DEPTH.0..=COURTYARD_DEPTH.1);
    let split = b.u0 + b.width() * rng.random_range(0.4..=0.6);
    let parts = if split - b.u0 >= 2.0 * d + 10.0 && b.u1 - split >= 2.0 * d + 10.0 {
        vec![(b.u0, split), (split, b.u1)]
    } else {
        vec![(b.u0, b.u1)]
    };
    parts
        .into_iter()
        .map(|(u0, u1)| GridBuilding {
            kind: Kind::Courtyard,
            outer: rect(u0, b.v0, u1, b.v1),
            hole: Some(rect(u0 + d, b.v0 + d, u1 - d, b.v1 - d)),
            height: low_height(rng, (4, 8)),
        })
        .collect()
}

/// Free-standing houses on lots along all four streets, gardens behind.
/// South and north lots run the full width; west and east lots stay clear
/// of the deepest south and north house.
fn houses(rng: &mut ChaCha8Rng, b: GridRect) -> Vec<GridBuilding> {
    let reach = HOUSE_SETBACK.1 + HOUSE_DEPTH.1 + 2.0;
    let mut out = Vec::new();
    // (lot start, lot end along the street, street side), per side.
    let sides: [(f64, f64, u8); 4] = [
        (b.u0, b.u1, 0),
        (b.u0, b.u1, 1),
        (b.v0 + reach, b.v1 - reach, 2),
        (b.v0 + reach, b.v1 - reach, 3),
    ];
    for (start, end, side) in sides {
        // Equal lots, each at least HOUSE_WIDTH.0 + 4 m wide (2 m gaps at both ends).
        let count = ((end - start) / LOT_WIDTH).round().max(1.0);
        let lot_width = (end - start) / count;
        if lot_width < HOUSE_WIDTH.0 + 4.0 {
            continue;
        }
        for i in 0..count as usize {
            let lot_start = start + i as f64 * lot_width;
            let width = rng.random_range(HOUSE_WIDTH.0..=HOUSE_WIDTH.1.min(lot_width - 4.0));
            let offset = rng.random_range(2.0..=lot_width - width - 2.0);
            let (a, z) = (lot_start + offset, lot_start + offset + width);
            let setback = rng.random_range(HOUSE_SETBACK.0..=HOUSE_SETBACK.1);
            let depth = rng.random_range(HOUSE_DEPTH.0..=HOUSE_DEPTH.1);
            let outer = match side {
                0 => rect(a, b.v0 + setback, z, b.v0 + setback + depth),
                1 => rect(a, b.v1 - setback - depth, z, b.v1 - setback),
                2 => rect(b.u0 + setback, a, b.u0 + setback + depth, z),
                _ => rect(b.u1 - setback - depth, a, b.u1 - setback, z),
            };
            out.push(GridBuilding {
                kind: Kind::House,
                outer,
                hole: None,
                height: low_height(rng, (2, 3)),
            });
        }
    }
    out
}

/// One or two free-standing towers on a plaza.
fn towers(rng: &mut ChaCha8Rng, b: GridRect) -> Vec<GridBuilding> {
    let halves = if b.width() >= 2.0 * TOWER_SIDE.1 + 20.0 && rng.random_bool(0.5) {
        vec![
            (b.u0, b.u0 + 0.5 * b.width()),
            (b.u0 + 0.5 * b.width(), b.u1),
        ]
    } else {
        vec![(b.u0, b.u1)]
    };
    halves
        .into_iter()
        .map(|(u0, u1)| {
            let side = rng.random_range(TOWER_SIDE.0..=TOWER_SIDE.1);
            let room_u = (u1 - u0) - side - 10.0;
            let room_v = b.depth() - side - 10.0;
            let cu = u0 + 5.0 + rng.random_range(0.0..=room_u);
            let cv = b.v0 + 5.0 + rng.random_range(0.0..=room_v);
            let height = rng.random_range(TOWER_HEIGHT.0..=TOWER_HEIGHT.1);
            GridBuilding {
                kind: Kind::Tower,
                outer: rect(cu, cv, cu + side, cv + side),
                hole: None,
                height: (height * 10.0).round() / 10.0,
            }
        })
        .collect()
}
