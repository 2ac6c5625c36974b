//! The one uniform grid of the crate: an origin, a cell size, `nx` by `ny`
//! cells, the clamped key of a point, the key range of a rectangle, the keys
//! in a rectangle or in a Chebyshev ring, each cell's rectangle, and the
//! per-cell item lists (CSR layout) every bucket index is built from.
//!
//! The grid only does the arithmetic: each user chooses its origin, cell
//! size and dimensions (and says why in its own module), so that moving a
//! bucket index onto this type changes no result.

use glam::DVec2;

use crate::model::Rect;

/// `nx` by `ny` cells of `cell.x` by `cell.y` metres from `origin`; cell
/// (x, y) covers `[origin + (x, y) * cell, origin + (x + 1, y + 1) * cell)`
/// and has index `y * nx + x`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformGrid {
    origin: DVec2,
    cell: DVec2,
    nx: usize,
    ny: usize,
}

/// A cell's column and row.
pub type Key = (usize, usize);

impl UniformGrid {
    /// A grid of square cells of side `size` (at least one cell each way).
    pub fn square(origin: DVec2, size: f64, nx: usize, ny: usize) -> UniformGrid {
        UniformGrid::new(origin, DVec2::splat(size), nx, ny)
    }

    /// A grid of `cell.x` by `cell.y` cells (at least one cell each way).
    pub fn new(origin: DVec2, cell: DVec2, nx: usize, ny: usize) -> UniformGrid {
        UniformGrid {
            origin,
            cell,
            nx: nx.max(1),
            ny: ny.max(1),
        }
    }

    /// The number of cells a grid of `size` squares from `bounds.min` needs
    /// to cover `bounds` (its far sides on a cell's far side), each way.
    pub fn cells_to_cover(bounds: &Rect, size: f64) -> (usize, usize) {
        (
            ((bounds.width() / size).ceil() as usize).max(1),
            ((bounds.height() / size).ceil() as usize).max(1),
        )
    }

    pub fn origin(&self) -> DVec2 {
        self.origin
    }

    /// The side of a cell along x (the side of every cell of a square grid).
    pub fn cell_size(&self) -> f64 {
        self.cell.x
    }

    pub fn nx(&self) -> usize {
        self.nx
    }

    pub fn ny(&self) -> usize {
        self.ny
    }

    /// How many cells there are.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Never true (a grid has at least one cell); here for clippy's sake.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Index of cell `key`.
    pub fn index(&self, (x, y): Key) -> usize {
        y * self.nx + x
    }

    /// The cell column and row of `p`, unclamped (possibly outside the grid).
    pub fn cell_of(&self, p: DVec2) -> (i64, i64) {
        let q = ((p - self.origin) / self.cell).floor();
        (q.x as i64, q.y as i64)
    }

    /// The key of the cell holding `p`, clamped into the grid (a point
    /// outside goes to the nearest border cell; NaN goes to column or row 0).
    pub fn key(&self, p: DVec2) -> Key {
        // `as usize` truncates and saturates: for q >= 0 that is the floor,
        // and below 0 (and for NaN) it gives 0, as the clamp would, with no
        // call to `floor` (the default x86-64 target has no instruction).
        let q = (p - self.origin) / self.cell;
        let x = (q.x as usize).min(self.nx - 1);
        let y = (q.y as usize).min(self.ny - 1);
        (x, y)
    }

    /// The first and last (clamped) key of the cells `rect` touches.
    pub fn key_range(&self, rect: &Rect) -> (Key, Key) {
        (self.key(rect.min), self.key(rect.max))
    }

    /// Whether `rect` lies wholly beyond one side of the grid (so that the
    /// clamped key range would only name border cells it does not touch).
    pub fn misses(&self, rect: &Rect) -> bool {
        let lo = (rect.min - self.origin) / self.cell;
        let hi = (rect.max - self.origin) / self.cell;
        hi.x < 0.0 || hi.y < 0.0 || lo.x >= self.nx as f64 || lo.y >= self.ny as f64
    }

    /// Call `f` with the index of every cell from key `lo` to key `hi`, row
    /// by row.
    pub fn for_each_in_range(&self, (lo, hi): (Key, Key), mut f: impl FnMut(usize)) {
        for y in lo.1..=hi.1 {
            for x in lo.0..=hi.0 {
                f(y * self.nx + x);
            }
        }
    }

    /// Call `f` with the index of every cell of the clamped key range of `rect`.
    pub fn for_each_in_rect(&self, rect: &Rect, f: impl FnMut(usize)) {
        self.for_each_in_range(self.key_range(rect), f);
    }

    /// How many cells the key range holds.
    pub fn range_len(&self, (lo, hi): (Key, Key)) -> u64 {
        ((hi.0 - lo.0 + 1) * (hi.1 - lo.1 + 1)) as u64
    }

    /// The largest Chebyshev ring (in cells) around `p`'s cell that still
    /// touches the grid.
    pub fn max_ring(&self, p: DVec2) -> i64 {
        let (x, y) = self.cell_of(p);
        let dx = x.abs().max((x - (self.nx as i64 - 1)).abs());
        let dy = y.abs().max((y - (self.ny as i64 - 1)).abs());
        dx.max(dy)
    }

    /// Call `f` with the index of every grid cell at Chebyshev distance
    /// exactly `ring` from the (unclamped) cell of `p`: the bottom and top
    /// rows left to right, then the left and right columns upwards.
    pub fn for_each_in_ring(&self, p: DVec2, ring: i64, mut f: impl FnMut(usize)) {
        self.for_each_in_ring_keyed(p, ring, |_, _, k| f(k));
    }

    /// [`UniformGrid::for_each_in_ring`], calling `f` with each cell's
    /// column, row and index.
    pub fn for_each_in_ring_keyed(
        &self,
        p: DVec2,
        ring: i64,
        mut f: impl FnMut(usize, usize, usize),
    ) {
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let (cx, cy) = self.cell_of(p);
        let mut visit = |x: i64, y: i64| {
            if x >= 0 && y >= 0 && x < nx && y < ny {
                f(x as usize, y as usize, (y * nx + x) as usize);
            }
        };
        if ring == 0 {
            visit(cx, cy);
            return;
        }
        for x in cx - ring..=cx + ring {
            visit(x, cy - ring);
            visit(x, cy + ring);
        }
        for y in cy - ring + 1..cy + ring {
            visit(cx - ring, y);
            visit(cx + ring, y);
        }
    }

    /// The rectangle cell `index` covers.
    pub fn cell_rect(&self, index: usize) -> Rect {
        let min = self.origin
            + DVec2::new((index % self.nx) as f64, (index / self.nx) as f64) * self.cell;
        Rect {
            min,
            max: min + self.cell,
        }
    }

    /// The x of the far side of column `x` when walking towards +x
    /// (`forward`), else its near side: where a ray leaves the column.
    pub fn column_exit(&self, x: usize, forward: bool) -> f64 {
        self.origin.x + (x as f64 + if forward { 1.0 } else { 0.0 }) * self.cell.x
    }

    /// The y where a ray leaves row `y` (see [`UniformGrid::column_exit`]).
    pub fn row_exit(&self, y: usize, forward: bool) -> f64 {
        self.origin.y + (y as f64 + if forward { 1.0 } else { 0.0 }) * self.cell.y
    }
}

/// Per grid cell, a list of item numbers (CSR layout): item `i` is listed in
/// every cell of its key range, each list ascending.
#[derive(Clone, Debug)]
pub struct CellLists {
    /// Items of cell `k` are `items[starts[k]..starts[k + 1]]`.
    starts: Vec<u32>,
    items: Vec<u32>,
}

impl CellLists {
    /// The lists of `count` items over `grid`, item `i` covering the key
    /// range `range(i)`. Two passes (count, then fill), so the caller can
    /// check [`CellLists::total`] first.
    pub fn build(grid: &UniformGrid, count: usize, range: impl Fn(usize) -> (Key, Key)) -> Self {
        let mut starts = vec![0u32; grid.len() + 1];
        for i in 0..count {
            grid.for_each_in_range(range(i), |k| starts[k + 1] += 1);
        }
        for k in 0..grid.len() {
            starts[k + 1] += starts[k];
        }
        let mut fill = starts.clone();
        let mut items = vec![0u32; starts[grid.len()] as usize];
        for i in 0..count {
            grid.for_each_in_range(range(i), |k| {
                items[fill[k] as usize] = i as u32;
                fill[k] += 1;
            });
        }
        CellLists { starts, items }
    }

    /// How many entries lists of `count` items with key ranges `range`
    /// would hold, without building them.
    pub fn total(grid: &UniformGrid, count: usize, range: impl Fn(usize) -> (Key, Key)) -> u64 {
        (0..count).map(|i| grid.range_len(range(i))).sum()
    }

    /// No lists at all (a grid of no cells).
    pub fn none() -> CellLists {
        CellLists {
            starts: vec![0],
            items: Vec::new(),
        }
    }

    /// The items of cell `k`.
    pub fn get(&self, k: usize) -> &[u32] {
        &self.items[self.starts[k] as usize..self.starts[k + 1] as usize]
    }

    /// Every cell's list, by cell index.
    pub fn iter(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.starts
            .windows(2)
            .map(|w| &self.items[w[0] as usize..w[1] as usize])
    }

    /// Entries over all lists.
    pub fn entries(&self) -> usize {
        self.items.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_clamp_and_ranges_cover() {
        let g = UniformGrid::square(DVec2::new(10.0, 20.0), 5.0, 4, 3);
        assert_eq!(g.len(), 12);
        assert_eq!(g.key(DVec2::new(10.0, 20.0)), (0, 0));
        assert_eq!(g.key(DVec2::new(14.999, 24.999)), (0, 0));
        assert_eq!(g.key(DVec2::new(15.0, 25.0)), (1, 1));
        assert_eq!(g.key(DVec2::new(-1e9, 1e9)), (0, 2));
        assert_eq!(g.key(DVec2::new(f64::NAN, 1e300)), (0, 2));
        // The key is the floor of the cell position, clamped, for every
        // kind of value (just below a cell's edge, below the origin,
        // infinite, NaN).
        let clamped_floor = |q: f64, n: usize| (q.floor().max(0.0) as usize).min(n - 1);
        let values = [
            -7.0, -1.0, -0.5, -1e-300, 0.0, 0.999999, 1.0, 2.5, 3.999, 4.0, 1e20,
        ];
        let odd = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];
        for &qx in values.iter().chain(&odd) {
            for &qy in values.iter().chain(&odd) {
                let p = DVec2::new(10.0 + 5.0 * qx, 20.0 + 5.0 * qy);
                let q = (p - DVec2::new(10.0, 20.0)) / 5.0;
                assert_eq!(
                    g.key(p),
                    (clamped_floor(q.x, 4), clamped_floor(q.y, 3)),
                    "{p}"
                );
            }
        }
        assert_eq!(g.cell_of(DVec2::new(4.0, 31.0)), (-2, 2));
        let r = Rect {
            min: DVec2::new(12.0, 21.0),
            max: DVec2::new(21.0, 26.0),
        };
        let mut seen = Vec::new();
        g.for_each_in_rect(&r, |k| seen.push(k));
        assert_eq!(seen, vec![0, 1, 2, 4, 5, 6]);
        assert_eq!(g.range_len(g.key_range(&r)), 6);
        assert_eq!(g.cell_rect(6).min, DVec2::new(20.0, 25.0));
        assert_eq!(g.cell_rect(6).max, DVec2::new(25.0, 30.0));
        assert!(g.misses(&Rect {
            min: DVec2::new(30.0, 0.0),
            max: DVec2::new(40.0, 100.0)
        }));
        assert!(!g.misses(&r));
    }

    #[test]
    fn rings_visit_each_cell_once_at_its_chebyshev_distance() {
        let g = UniformGrid::square(DVec2::ZERO, 1.0, 7, 5);
        let p = DVec2::new(1.5, 3.5);
        let mut count = vec![0; g.len()];
        for ring in 0..=g.max_ring(p) {
            g.for_each_in_ring(p, ring, |k| {
                count[k] += 1;
                let (x, y) = ((k % 7) as i64, (k / 7) as i64);
                assert_eq!((x - 1).abs().max((y - 3).abs()), ring);
            });
        }
        assert!(count.iter().all(|&c| c == 1), "{count:?}");
    }

    #[test]
    fn cell_lists_hold_each_item_where_its_range_says() {
        let g = UniformGrid::new(DVec2::ZERO, DVec2::new(2.0, 1.0), 3, 2);
        let ranges = [((0, 0), (1, 0)), ((1, 0), (2, 1)), ((2, 1), (2, 1))];
        let lists = CellLists::build(&g, 3, |i| ranges[i]);
        let got: Vec<Vec<u32>> = lists.iter().map(|l| l.to_vec()).collect();
        assert_eq!(
            got,
            vec![vec![0], vec![0, 1], vec![1], vec![], vec![1], vec![1, 2]]
        );
        assert_eq!(CellLists::total(&g, 3, |i| ranges[i]), 7);
        assert_eq!(lists.entries(), 7);
        assert_eq!(lists.get(5), &[1, 2]);
    }
}
