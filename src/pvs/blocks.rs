//! The coding of the visible sets inside a block (docs/FORMAT.md, "Blocks"):
//! one range-coded stream per block. Each cell names up to two earlier cells
//! of its block as references; its set is coded word by word (64 ranks),
//! a word equal to the first reference's costing one well-predicted flag,
//! and the ranks of the other words coded one binary decision each, in the
//! context of the two references' bits at that rank and the cell's own bit
//! (and its difference from the first reference) at the rank before. The
//! models start afresh at every block, so a cell decodes from its block
//! alone. Also the LEB128 varints of the other sections.

use super::rc::{BitCoder, Decoder, Encoder, PROB_INIT, PastEnd, Prob};

/// Coding names for reports, index = how many references the cell used.
pub const CODING_NAMES: [&str; 3] = ["whole", "one-reference", "two-references"];

/// Most bits of a reference (blocks of at most 1024 cells).
const MAX_REF_BITS: u32 = 10;

/// Bits of a reference in blocks of `block_cells` cells: the bit length of
/// `block_cells - 1` (at least 1), so any earlier cell of the block can be
/// named (docs/FORMAT.md, "Blocks").
pub fn ref_bits(block_cells: u32) -> u32 {
    (32 - block_cells.saturating_sub(1).leading_zeros()).clamp(1, MAX_REF_BITS)
}

/// Ranks per word of a set's bitset.
const WORD: usize = 64;
/// What a cell difference at one rank costs in the writer's choice of the
/// second reference, against 1 for a rank where the references disagree.
const MISS_COST: u32 = 6;

/// Bytes of `v` as a LEB128 varint.
pub fn varint_len(v: u64) -> usize {
    (64 - (v | 1).leading_zeros() as usize).div_ceil(7)
}

/// Read a LEB128 varint of at most 10 bytes whose value fits in 64 bits.
pub fn read_varint(bytes: &[u8], pos: &mut usize) -> Result<u64, String> {
    let mut value: u64 = 0;
    for i in 0..10 {
        let Some(&byte) = bytes.get(*pos) else {
            return Err("varint runs past the end of the section".into());
        };
        *pos += 1;
        let bits = u64::from(byte & 0x7f);
        if i == 9 && bits > 1 {
            return Err("varint exceeds 2^64 - 1".into());
        }
        value |= bits << (7 * i);
        if byte & 0x80 == 0 {
            return Ok(value);
        }
    }
    Err("varint longer than 10 bytes".into())
}

/// The adaptive probabilities of one block (docs/FORMAT.md, "Blocks").
#[derive(Clone)]
struct Models {
    /// Bit trees of the first and the second reference (`ref_bits` bits,
    /// at most 10).
    back_a: [Prob; 1 << MAX_REF_BITS],
    back_b: [Prob; 1 << MAX_REF_BITS],
    /// "The word differs from the first reference's", context: references'
    /// words equal (1), previous word differed (2), first reference's word
    /// zero (4), every earlier cell of the block has the first reference's
    /// word (8).
    word: [Prob; 16],
    /// One rank of a differing word, context: first reference's bit (1),
    /// second's (2), the cell's bit differed from the first reference at the
    /// rank before (4), the cell's bit at the rank before (8), an earlier
    /// cell of the block has the other bit here (16), the cell had the first
    /// reference's bit at the last rank where the references differed (32).
    rank: [Prob; 64],
}

impl Models {
    fn new() -> Self {
        Models {
            back_a: [PROB_INIT; 1 << MAX_REF_BITS],
            back_b: [PROB_INIT; 1 << MAX_REF_BITS],
            word: [PROB_INIT; 16],
            rank: [PROB_INIT; 64],
        }
    }
}

#[inline]
fn word_context(a: u64, b: u64, previous_differed: bool, settled: bool) -> usize {
    usize::from(a == b)
        | (usize::from(previous_differed) << 1)
        | (usize::from(a == 0) << 2)
        | (usize::from(settled) << 3)
}

/// Code (encoder) or decode (decoder) one cell's set against its references
/// `ra`, `rb` and the block's union and intersection so far: `row` holds the
/// set when encoding and receives it when decoding.
fn code_set<C: BitCoder>(
    rc: &mut C,
    m: &mut Models,
    n: usize,
    ra: &[u64],
    rb: &[u64],
    seen: (&[u64], &[u64]),
    row: &mut [u64],
) -> Result<(), PastEnd> {
    let (union, inter) = seen;
    let mut previous_word = false;
    // At the last rank where the references differed, the cell had the
    // first reference's bit (1 before any such rank).
    let mut last_split = 1usize;
    for i in 0..row.len() {
        let (aw, bw, cw) = (ra[i], rb[i], row[i]);
        let (uw, iw) = (union[i], inter[i]);
        let wctx = word_context(aw, bw, previous_word, uw == aw && iw == aw);
        let differs = rc.code(&mut m.word[wctx], u32::from(cw != aw))? == 1;
        previous_word = differs;
        if !differs {
            row[i] = aw;
            if aw != bw {
                last_split = 1;
            }
            continue;
        }
        // The cell's bit and its difference from `ra` at the rank before.
        let (mut pc, mut pd) = if i == 0 {
            (0, 0)
        } else {
            (
                (row[i - 1] >> 63) as usize,
                ((row[i - 1] ^ ra[i - 1]) >> 63) as usize,
            )
        };
        let mut out = 0u64;
        for j in 0..WORD.min(n - i * WORD) {
            let (x, y) = (((aw >> j) & 1) as usize, ((bw >> j) & 1) as usize);
            // Has an earlier cell of the block the other bit at this rank?
            let e = if x == 0 {
                (uw >> j) & 1
            } else {
                !(iw >> j) & 1
            } as usize;
            let ctx = x | y << 1 | pd << 2 | pc << 3 | e << 4 | last_split << 5;
            let c = rc.code(&mut m.rank[ctx], ((cw >> j) & 1) as u32)? as usize;
            out |= (c as u64) << j;
            if x != y {
                last_split = usize::from(c == x);
            }
            pd = c ^ x;
            pc = c;
        }
        row[i] = out;
    }
    Ok(())
}

/// The union and the intersection of the block's sets so far (the
/// intersection starts as every rank below `n`).
struct Seen {
    union: Vec<u64>,
    inter: Vec<u64>,
}

impl Seen {
    fn new(n: usize) -> Self {
        let mut inter = vec![u64::MAX; n.div_ceil(WORD)];
        if !n.is_multiple_of(WORD) {
            inter[n / WORD] = (1u64 << (n % WORD)) - 1;
        }
        Seen {
            union: vec![0; inter.len()],
            inter,
        }
    }
    fn get(&self) -> (&[u64], &[u64]) {
        (&self.union, &self.inter)
    }
    fn add(&mut self, row: &[u64]) {
        for ((u, i), r) in self.union.iter_mut().zip(&mut self.inter).zip(row) {
            *u |= r;
            *i &= r;
        }
    }
}

/// Codes the cells of one block; [`BlockEncoder::push`] one set at a time,
/// then [`BlockEncoder::finish`].
pub struct BlockEncoder {
    n: usize,
    /// Cells per block, and the bits of a reference.
    block_cells: usize,
    ref_bits: u32,
    words: usize,
    /// Bitsets of the block's cells so far, `words` each.
    rows: Vec<u64>,
    /// The number of ranks in each of those rows.
    row_counts: Vec<u32>,
    /// The words of the cell being coded that hold a rank, or that differ
    /// from its first reference (reused from cell to cell).
    some_words: Vec<usize>,
    cells: usize,
    models: Models,
    rc: Encoder,
    zero: Vec<u64>,
    seen: Seen,
}

impl BlockEncoder {
    /// An encoder for sets of ranks below `n` in blocks of `block_cells`
    /// cells (1 to 1024).
    pub fn new(n: u32, block_cells: u32) -> Self {
        let words = (n as usize).div_ceil(WORD);
        BlockEncoder {
            n: n as usize,
            block_cells: block_cells as usize,
            ref_bits: ref_bits(block_cells),
            words,
            rows: Vec::new(),
            row_counts: Vec::new(),
            some_words: Vec::new(),
            cells: 0,
            models: Models::new(),
            rc: Encoder::new(),
            zero: vec![0; words],
            seen: Seen::new(n as usize),
        }
    }

    /// Cells coded in the current block.
    pub fn len(&self) -> usize {
        self.cells
    }
    pub fn is_empty(&self) -> bool {
        self.cells == 0
    }

    fn row(&self, k: usize) -> &[u64] {
        &self.rows[k * self.words..(k + 1) * self.words]
    }

    /// Code the next cell's set, ascending ranks below `n` (at most
    /// `block_cells` cells per block). Returns how many references it used.
    pub fn push(&mut self, ranks: &[u32]) -> u8 {
        let (w, k) = (self.words, self.cells);
        assert!(
            k < self.block_cells,
            "at most {} cells per block",
            self.block_cells
        );
        let at = k * w;
        self.rows.resize(at + w, 0);
        for &r in ranks {
            self.rows[at + r as usize / WORD] |= 1 << (r as usize % WORD);
        }
        let cur = &self.rows[at..at + w];
        let count: u32 = cur.iter().map(|x| x.count_ones()).sum();
        // First reference: the earlier cell nearest in Hamming distance
        // (ties: the nearest cell), if nearer than the empty set. The
        // distance is |row| + |cur| - 2 |row & cur|, the last read only in
        // the words where `cur` holds a rank (sets are sparse).
        let mut words = std::mem::take(&mut self.some_words);
        words.clear();
        words.extend((0..w).filter(|&i| cur[i] != 0));
        let mut a = 0usize;
        let mut best = ranks.len() as u32;
        for back in 1..=k {
            let row = self.row(k - back);
            let common: u32 = words.iter().map(|&i| (row[i] & cur[i]).count_ones()).sum();
            let d = self.row_counts[k - back] + count - 2 * common;
            if d < best {
                (a, best) = (back, d);
            }
        }
        // Second reference: the one that best settles the first one's misses
        // in the words where the first differs (ties: none, then nearest).
        let mut b = 0usize;
        if a > 0 && k >= 2 {
            let ra = self.row(k - a);
            words.clear();
            words.extend((0..w).filter(|&i| ra[i] != cur[i]));
            let cost = |rb: &[u64]| -> u32 {
                let mut c = 0;
                for &i in &words {
                    let miss = ra[i] ^ cur[i];
                    let split = ra[i] ^ rb[i];
                    c += split.count_ones() + MISS_COST * (miss & !split).count_ones();
                }
                c
            };
            let mut best = cost(ra);
            for back in 1..=k {
                if back != a {
                    let c = cost(self.row(k - back));
                    if c < best {
                        (b, best) = (back, c);
                    }
                }
            }
        }
        self.some_words = words;
        self.row_counts.push(count);
        let m = &mut self.models;
        if k >= 1 {
            let _ = self.rc.code_tree(&mut m.back_a, self.ref_bits, a as u32);
            if a > 0 && k >= 2 {
                let _ = self.rc.code_tree(&mut m.back_b, self.ref_bits, b as u32);
            }
        }
        let (ra, rb, row) = reference_rows(&mut self.rows, &self.zero, w, k, a, b);
        let _ = code_set(&mut self.rc, m, self.n, ra, rb, self.seen.get(), row);
        self.seen.add(row);
        self.cells += 1;
        u8::from(a > 0) + u8::from(b > 0)
    }

    /// The block's bytes; the encoder starts a new block.
    pub fn finish(&mut self) -> Vec<u8> {
        self.cells = 0;
        self.rows.clear();
        self.row_counts.clear();
        self.models = Models::new();
        self.seen = Seen::new(self.n);
        std::mem::take(&mut self.rc).finish()
    }
}

/// The rows of a block's cells (`w` words each) split at cell `k`: its
/// two reference sets, `a` and `b` cells back (`a` = 0: the empty set
/// `zero`; `b` = 0: the same as `a`), and its own row from there on.
fn reference_rows<'r>(
    rows: &'r mut [u64],
    zero: &'r [u64],
    w: usize,
    k: usize,
    a: usize,
    b: usize,
) -> (&'r [u64], &'r [u64], &'r mut [u64]) {
    let (done, row) = rows.split_at_mut(k * w);
    let done: &'r [u64] = done;
    let ra = if a > 0 {
        &done[(k - a) * w..(k - a + 1) * w]
    } else {
        zero
    };
    let rb = if b > 0 {
        &done[(k - b) * w..(k - b + 1) * w]
    } else {
        ra
    };
    (ra, rb, row)
}

/// Decodes the cells of one block in order. Memory: one bitset of `n` bits
/// per cell of the block, whatever the bytes say.
pub struct BlockDecoder<'a> {
    n: usize,
    block_cells: usize,
    ref_bits: u32,
    words: usize,
    rows: Vec<u64>,
    cells: usize,
    models: Models,
    rc: Decoder<'a>,
    zero: Vec<u64>,
    seen: Seen,
}

fn past_end(_: PastEnd) -> String {
    "the block's coding runs past the end of the block".into()
}

impl<'a> BlockDecoder<'a> {
    /// Start decoding a block of sets of ranks below `n`, in blocks of
    /// `block_cells` cells (1 to 1024).
    pub fn new(bytes: &'a [u8], n: u32, block_cells: u32) -> Result<Self, String> {
        let words = (n as usize).div_ceil(WORD);
        Ok(BlockDecoder {
            n: n as usize,
            block_cells: block_cells as usize,
            ref_bits: ref_bits(block_cells),
            words,
            rows: Vec::new(),
            cells: 0,
            models: Models::new(),
            rc: Decoder::new(bytes)?,
            zero: vec![0; words],
            seen: Seen::new(n as usize),
        })
    }

    /// Bytes of the block read so far.
    pub fn pos(&self) -> usize {
        self.rc.pos()
    }

    /// Decode the next cell (at most `block_cells` per block): its
    /// ascending ranks go to `set`; returns how many references it used.
    pub fn next(&mut self, set: &mut Vec<u32>) -> Result<u8, String> {
        let (w, k) = (self.words, self.cells);
        if k >= self.block_cells {
            return Err(format!("more than {} cells in a block", self.block_cells));
        }
        let m = &mut self.models;
        let (mut a, mut b) = (0usize, 0usize);
        if k >= 1 {
            a = self
                .rc
                .tree(&mut m.back_a, self.ref_bits)
                .map_err(past_end)? as usize;
            if a > k {
                return Err(format!(
                    "a cell refers {a} cells back, but {k} cells precede it in its block"
                ));
            }
            if a > 0 && k >= 2 {
                b = self
                    .rc
                    .tree(&mut m.back_b, self.ref_bits)
                    .map_err(past_end)? as usize;
                if b > k {
                    return Err(format!(
                        "a cell refers {b} cells back, but {k} cells precede it in its block"
                    ));
                }
            }
        }
        let at = k * w;
        self.rows.resize(at + w, 0);
        let (ra, rb, row) = reference_rows(&mut self.rows, &self.zero, w, k, a, b);
        code_set(&mut self.rc, m, self.n, ra, rb, self.seen.get(), row).map_err(past_end)?;
        self.seen.add(row);
        set.clear();
        for (i, &word) in row.iter().enumerate() {
            let mut word = word;
            while word != 0 {
                set.push((i * WORD) as u32 + word.trailing_zeros());
                word &= word - 1;
            }
        }
        self.cells += 1;
        Ok(u8::from(a > 0) + u8::from(b > 0))
    }
}

#[cfg(test)]
mod tests {
    use super::super::codec::write_leb128;
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn reference_bits_name_every_earlier_cell() {
        assert_eq!(ref_bits(1), 1);
        assert_eq!(ref_bits(2), 1);
        assert_eq!(ref_bits(128), 7);
        assert_eq!(ref_bits(256), 8);
        assert_eq!(ref_bits(512), 9);
        assert_eq!(ref_bits(1024), 10);
        for cells in 2..=1024u32 {
            assert!(cells - 1 < 1 << ref_bits(cells), "{cells}");
        }
    }

    #[test]
    fn varint_lengths() {
        for v in [
            0u64,
            1,
            127,
            128,
            16383,
            16384,
            u64::from(u32::MAX),
            u64::MAX,
        ] {
            let mut out = Vec::new();
            write_leb128(&mut out, v);
            assert_eq!(out.len(), varint_len(v), "{v}");
            let mut pos = 0;
            assert_eq!(read_varint(&out, &mut pos).unwrap(), v);
        }
        let mut pos = 0;
        assert!(read_varint(&[0xff; 10], &mut pos).is_err());
        let mut pos = 0;
        assert!(
            read_varint(
                &[0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x02],
                &mut pos
            )
            .is_err()
        );
    }

    #[test]
    fn references_are_chosen_and_identical_sets_cost_little() {
        let mut e = BlockEncoder::new(300, 256);
        let base: Vec<u32> = (0..300).filter(|r| r % 3 == 0).collect();
        assert_eq!(e.push(&base), 0);
        let mut other = base.clone();
        other.push(299);
        assert_eq!(e.push(&other), 1);
        let one = e.rc.len();
        for _ in 0..100 {
            e.push(&base);
        }
        let bytes = e.finish();
        // A hundred copies of an earlier set: well under a byte each.
        assert!(bytes.len() < one + 5 + 60, "{} bytes", bytes.len());
        let mut d = BlockDecoder::new(&bytes, 300, 256).unwrap();
        let mut set = Vec::new();
        d.next(&mut set).unwrap();
        assert_eq!(set, base);
        d.next(&mut set).unwrap();
        assert_eq!(set, other);
        for _ in 0..100 {
            d.next(&mut set).unwrap();
            assert_eq!(set, base);
        }
        assert_eq!(d.pos(), bytes.len());
    }

    proptest! {
        #[test]
        fn cells_round_trip(n in 1u32..3000, cells in proptest::collection::vec(proptest::collection::vec(any::<u32>(), 0..200), 1..12), extra in 0u32..1013) {
            // Any block size that holds the cells: the references' bits follow it.
            let block_cells = cells.len() as u32 + extra;
            let sets: Vec<Vec<u32>> = cells.iter().map(|c| {
                let mut s: Vec<u32> = c.iter().map(|v| v % n).collect();
                s.sort_unstable();
                s.dedup();
                s
            }).collect();
            let mut e = BlockEncoder::new(n, block_cells);
            for round in 0..2 {
                for s in &sets {
                    e.push(s);
                }
                let bytes = e.finish();
                let mut d = BlockDecoder::new(&bytes, n, block_cells).unwrap();
                let mut set = Vec::new();
                for s in &sets {
                    d.next(&mut set).unwrap();
                    prop_assert_eq!(&set, s, "round {}", round);
                }
                prop_assert_eq!(d.pos(), bytes.len());
            }
        }

        #[test]
        fn arbitrary_bytes_never_panic(n in 0u32..300, bytes in proptest::collection::vec(any::<u8>(), 0..60)) {
            if let Ok(mut d) = BlockDecoder::new(&bytes, n, 256) {
                let mut set = Vec::new();
                for _ in 0..300 {
                    if d.next(&mut set).is_err() {
                        break;
                    }
                    prop_assert!(set.windows(2).all(|w| w[0] < w[1]));
                    prop_assert!(set.iter().all(|&i| i < n));
                    prop_assert!(d.pos() <= bytes.len());
                }
            }
        }
    }
}
