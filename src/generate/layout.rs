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
    /// The river-like strip's extent in v (it runs the whole length in u).
    pub river: (f64, f64),
}

/// Block boundaries along one axis covering [-half, half]: pairs (start, end)
/// of the blocks, separated by streets. If `river_at` is given, the first
/// street line past that coordinate is widened into the river; its extent is
/// returned.
fn axis(rng: &mut ChaCha8Rng, half: f64, river_at: Option<f64>) -> (Vec<(f64, f64)>, (f64, f64)) {
    let mut blocks = Vec::new();
    let mut river = (f64::NAN, f64::NAN);
    let mut river_done = river_at.is_none();
    let mut pos = -half;
    while pos < half {
        let start = pos;
        let end = start + rng.random_range(BLOCK_SIDE.0..=BLOCK_SIDE.1);
        blocks.push((start, end));
        let mut street = if rng.random_bool(AVENUE_CHANCE) {
            rng.random_range(AVENUE_WIDTH.0..=AVENUE_WIDTH.1)
        } else {
            rng.random_range(STREET_WIDTH.0..=STREET_WIDTH.1)
        };
        if !river_done && river_at.is_some_and(|at| end > at) {
            street = rng.random_range(RIVER_WIDTH.0..=RIVER_WIDTH.1);
            river = (end, end + street);
            river_done = true;
        }
        pos = end + street;
    }
    (blocks, river)
}

/// A street plan covering a square of side `2 * half` around the origin,
/// for a city of about `radius` metres; blocks sorted by distance from the
/// centre (ties broken by row, then column).
pub fn plan(rng: &mut ChaCha8Rng, half: f64, radius: f64) -> Layout {
    let (columns, _) = axis(rng, half, None);
    let (rows, river) = axis(rng, half, Some(0.3 * radius));
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
    if let Some(nearest) = blocks
        .iter()
        .enumerate()
        .min_by(|a, b| distance(a.1, target).total_cmp(&distance(b.1, target)))
        .map(|(i, _)| i)
    {
        let (row, column) = (blocks[nearest].row, blocks[nearest].column);
        for b in blocks.iter_mut() {
            if b.row == row && (b.column == column || b.column == column + 1) {
                b.square = true;
            }
        }
    }
    blocks.sort_by(|a, b| {
        distance(a, (0.0, 0.0))
            .total_cmp(&distance(b, (0.0, 0.0)))
            .then(a.row.cmp(&b.row))
            .then(a.column.cmp(&b.column))
    });
    Layout { blocks, river }
}
