//! The street plan of a generated city, in the grid frame (u along one
//! street direction, v along the other, metres, before the 15 degree
//! rotation): street lines of varied width with a few avenues, blocks between
//! them, one river-like strip (a street line widened to 40-70 m) and one open
//! square (two neighbouring blocks left empty).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Street widths in metres: ordinary streets and the wider avenues.
const STREET_WIDTH: (f64, f64) = (12.0, 18.0);
const AVENUE_WIDTH: (f64, f64) = (22.0, 25.0);
/// Chance that a street line is an avenue.
const AVENUE_CHANCE: f64 = 0.15;
/// Block side lengths in metres.
pub const BLOCK_SIDE: (f64, f64) = (60.0, 120.0);
/// Width of the river-like strip in metres.
pub const RIVER_WIDTH: (f64, f64) = (40.0, 70.0);

/// An axis-aligned rectangle in the grid frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridRect {
    pub u0: f64,
    pub v0: f64,
    pub u1: f64,
    pub v1: f64,
}

impl GridRect {
    pub fn width(&self) -> f64 {
        self.u1 - self.u0
    }

    pub fn depth(&self) -> f64 {
        self.v1 - self.v0
    }

    pub fn centre(&self) -> (f64, f64) {
        (0.5 * (self.u0 + self.u1), 0.5 * (self.v0 + self.v1))
    }
}

/// One block of the street grid.
#[derive(Clone, Debug)]
pub struct Block {
    /// Column and row of the block in the grid; they name its random stream.
    pub column: usize,
    pub row: usize,
    pub rect: GridRect,
    /// True for the blocks of the open square (no buildings).
    pub square: bool,
}

/// The street plan: blocks ordered from the city centre outwards.
#[derive(Clone, Debug)]
pub struct Layout {
    pub blocks: Vec<Block>,
    /// The river-like strip: the whole plan's length in u.
    pub river: GridRect,
    /// The open square: the two empty blocks (the streets around stay streets).
    pub square: GridRect,
}

/// Block boundaries along one axis covering [-half, half]: pairs (start,
/// end) of the blocks, separated by streets of varied width.
fn axis(rng: &mut ChaCha8Rng, half: f64) -> Vec<(f64, f64)> {
    let mut blocks = Vec::new();
    let mut pos = -half;
    while pos < half {
        let end = pos + rng.random_range(BLOCK_SIDE.0..=BLOCK_SIDE.1);
        blocks.push((pos, end));
        let street = if rng.random_bool(AVENUE_CHANCE) {
            rng.random_range(AVENUE_WIDTH.0..=AVENUE_WIDTH.1)
        } else {
            rng.random_range(STREET_WIDTH.0..=STREET_WIDTH.1)
        };
        pos = end + street;
    }
    blocks
}

/// Widen the street line whose middle is nearest `at` into the river,
/// shifting the blocks beyond it; returns the river's extent.
fn widen_into_river(rng: &mut ChaCha8Rng, blocks: &mut [(f64, f64)], at: f64) -> (f64, f64) {
    let middle = |i: usize| 0.5 * (blocks[i].1 + blocks[i + 1].0);
    let line = (0..blocks.len() - 1)
        .min_by(|&a, &b| (middle(a) - at).abs().total_cmp(&(middle(b) - at).abs()))
        .expect("the plan has at least two blocks per axis");
    let width = rng.random_range(RIVER_WIDTH.0..=RIVER_WIDTH.1);
    let start = blocks[line].1;
    let shift = start + width - blocks[line + 1].0;
    for b in &mut blocks[line + 1..] {
        *b = (b.0 + shift, b.1 + shift);
    }
    (start, start + width)
}

/// A street plan covering a square of side `2 * half` around the origin,
/// for a city of about `radius` metres; blocks sorted by distance from the
/// centre (ties broken by row, then column).
pub fn plan(rng: &mut ChaCha8Rng, half: f64, radius: f64) -> Layout {
    let columns = axis(rng, half);
    let mut rows = axis(rng, half);
    let river = widen_into_river(rng, &mut rows, 0.2 * radius);
    // The square: the block nearest a point on the other side of the centre,
    // together with its eastern neighbour.
    let target = (-0.35 * radius, -0.3 * radius);
    let mut blocks = Vec::with_capacity(columns.len() * rows.len());
    for (row, &(v0, v1)) in rows.iter().enumerate() {
        for (column, &(u0, u1)) in columns.iter().enumerate() {
            blocks.push(Block {
                column,
                row,
                rect: GridRect { u0, v0, u1, v1 },
                square: false,
            });
        }
    }
    let distance = |b: &Block, (x, y): (f64, f64)| {
        let (u, v) = b.rect.centre();
        (u - x).hypot(v - y)
    };
    let nearest = blocks
        .iter()
        .filter(|b| b.column + 1 < columns.len())
        .min_by(|a, b| distance(a, target).total_cmp(&distance(b, target)))
        .map(|b| (b.row, b.column))
        .expect("the plan has at least two blocks per axis");
    let mut square = GridRect {
        u0: f64::INFINITY,
        v0: f64::INFINITY,
        u1: f64::NEG_INFINITY,
        v1: f64::NEG_INFINITY,
    };
    for b in blocks.iter_mut() {
        if b.row == nearest.0 && (b.column == nearest.1 || b.column == nearest.1 + 1) {
            b.square = true;
            square = GridRect {
                u0: square.u0.min(b.rect.u0),
                v0: square.v0.min(b.rect.v0),
                u1: square.u1.max(b.rect.u1),
                v1: square.v1.max(b.rect.v1),
            };
        }
    }
    blocks.sort_by(|a, b| {
        distance(a, (0.0, 0.0))
            .total_cmp(&distance(b, (0.0, 0.0)))
            .then(a.row.cmp(&b.row))
            .then(a.column.cmp(&b.column))
    });
    let river = GridRect {
        u0: columns[0].0,
        v0: river.0,
        u1: columns[columns.len() - 1].1,
        v1: river.1,
    };
    Layout {
        blocks,
        river,
        square,
    }
}

/// Cut positions from `start` to `end` (both included, exactly) into pieces
/// whose widths lie within `width`; `end - start` must be at least
/// `width.0` (and `width.1 - width.0 >= width.0`, so that a piece always fits).
pub fn cuts(rng: &mut ChaCha8Rng, start: f64, end: f64, width: (f64, f64)) -> Vec<f64> {
    let mut out = vec![start];
    let mut pos = start;
    while end - pos > width.1 {
        let w = rng.random_range(width.0..=width.1.min(end - pos - width.0));
        pos += w;
        out.push(pos);
    }
    out.push(end);
    out
}
