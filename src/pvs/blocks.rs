//! The coding of the visible sets inside a block (docs/FORMAT.md, "Blocks"):
//! each cell is one head varint (item count and mode) and a list of object
//! ranks, either the cell's whole set or its symmetric difference from the
//! previous cell of the block, as gaps or as runs. Decoding checks every
//! count against the bytes left before it expands anything.

use super::codec::write_leb128;

/// The list is the cell's set, as gap varints.
pub const MODE_SET_GAPS: u8 = 0;
/// The list is the difference from the previous cell's set, as gap varints.
pub const MODE_DIFF_GAPS: u8 = 1;
/// The list is the cell's set, as runs.
pub const MODE_SET_RUNS: u8 = 2;
/// The list is the difference from the previous cell's set, as runs.
pub const MODE_DIFF_RUNS: u8 = 3;
/// Names of the modes, index = mode.
pub const MODE_NAMES: [&str; 4] = ["set-gaps", "diff-gaps", "set-runs", "diff-runs"];

/// Bytes of `v` as a LEB128 varint.
pub fn varint_len(v: u64) -> usize {
    (64 - (v | 1).leading_zeros() as usize).div_ceil(7)
}

/// Read a LEB128 varint of at most 10 bytes whose value fits in 64 bits.
pub fn read_varint(bytes: &[u8], pos: &mut usize) -> Result<u64, String> {
    let mut value: u64 = 0;
    for i in 0..10 {
        let Some(&byte) = bytes.get(*pos) else {
            return Err("varint runs past the end of the block".into());
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

/// The symmetric difference of two ascending lists, ascending, into `out`.
pub fn symmetric_difference(a: &[u32], b: &[u32], out: &mut Vec<u32>) {
    out.clear();
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
}

/// Item count and byte length of `list` as gaps.
fn gaps_size(list: &[u32]) -> (u64, usize) {
    let mut next = 0u64;
    let mut bytes = 0;
    for &i in list {
        bytes += varint_len(u64::from(i) - next);
        next = u64::from(i) + 1;
    }
    (list.len() as u64, bytes)
}

/// Call `f(start, last)` for each maximal run of consecutive values.
fn for_runs(list: &[u32], mut f: impl FnMut(u32, u32)) {
    let mut k = 0;
    while k < list.len() {
        let mut end = k + 1;
        while end < list.len() && list[end] == list[end - 1] + 1 {
            end += 1;
        }
        f(list[k], list[end - 1]);
        k = end;
    }
}

/// Item count (runs) and byte length of `list` as runs.
fn runs_size(list: &[u32]) -> (u64, usize) {
    let (mut count, mut bytes, mut next) = (0u64, 0usize, 0u64);
    for_runs(list, |start, last| {
        count += 1;
        bytes += varint_len(u64::from(start) - next) + varint_len(u64::from(last - start));
        next = u64::from(last) + 2;
    });
    (count, bytes)
}

fn put_gaps(out: &mut Vec<u8>, list: &[u32]) {
    let mut next = 0u64;
    for &i in list {
        write_leb128(out, u64::from(i) - next);
        next = u64::from(i) + 1;
    }
}

fn put_runs(out: &mut Vec<u8>, list: &[u32]) {
    let mut next = 0u64;
    for_runs(list, |start, last| {
        write_leb128(out, u64::from(start) - next);
        write_leb128(out, u64::from(last - start));
        next = u64::from(last) + 2;
    });
}

/// Append the coding of `cur` (ascending ranks) given the sets of the
/// block's earlier cells, `earlier[0]` the first; `diff` is scratch. Writes
/// the shortest coding (the set itself, or its difference from one earlier
/// cell, each as gaps or runs; ties: lowest mode, then nearest cell) and
/// returns the mode.
pub fn encode_cell(
    earlier: &[Vec<u32>],
    cur: &[u32],
    diff: &mut Vec<u32>,
    out: &mut Vec<u8>,
) -> u8 {
    // (bytes, mode, back) of the best coding so far.
    let cost = |count: u64, bytes: usize, back: usize| {
        varint_len(count << 2) + bytes + if back > 0 { varint_len(back as u64) } else { 0 }
    };
    let mut best = {
        let (g, r) = (gaps_size(cur), runs_size(cur));
        let (cg, cr) = (cost(g.0, g.1, 0), cost(r.0, r.1, 0));
        if cr < cg {
            (cr, MODE_SET_RUNS, 0)
        } else {
            (cg, MODE_SET_GAPS, 0)
        }
    };
    for back in 1..=earlier.len() {
        let prev = &earlier[earlier.len() - back];
        if prev.len().abs_diff(cur.len()) + 1 >= best.0 {
            continue; // the difference holds at least this many items
        }
        symmetric_difference(prev, cur, diff);
        let (g, r) = (gaps_size(diff), runs_size(diff));
        let (cg, cr) = (cost(g.0, g.1, back), cost(r.0, r.1, back));
        if cg < best.0 {
            best = (cg, MODE_DIFF_GAPS, back);
        }
        if cr < best.0 {
            best = (cr, MODE_DIFF_RUNS, back);
        }
    }
    let (_, mode, back) = best;
    let list: &[u32] = if back == 0 {
        cur
    } else {
        symmetric_difference(&earlier[earlier.len() - back], cur, diff);
        diff
    };
    let count = if mode < 2 {
        gaps_size(list).0
    } else {
        runs_size(list).0
    };
    write_leb128(out, (count << 2) | u64::from(mode));
    if back > 0 {
        write_leb128(out, back as u64);
    }
    if mode < 2 {
        put_gaps(out, list);
    } else {
        put_runs(out, list);
    }
    mode
}

/// Decode one cell's coding at `bytes[*pos..]`, `earlier` cells preceding
/// it in its block: returns the mode and how many cells back its reference
/// is (0 = none, the list is the set itself), and leaves the list (ascending
/// ranks below `n`) in `list`.
pub fn decode_list(
    bytes: &[u8],
    pos: &mut usize,
    n: u32,
    earlier: usize,
    list: &mut Vec<u32>,
) -> Result<(u8, usize), String> {
    let head = read_varint(bytes, pos)?;
    let mode = (head & 3) as u8;
    let count = head >> 2;
    let back = if mode % 2 == 1 {
        let back = read_varint(bytes, pos)?;
        if back == 0 || back > earlier as u64 {
            return Err(format!(
                "a cell refers {back} cells back, but {earlier} cells precede it in its block"
            ));
        }
        back as usize
    } else {
        0
    };
    let left = (bytes.len() - *pos) as u64;
    let per_item = if mode < 2 { 1 } else { 2 };
    // Every item takes at least `per_item` bytes: refuse before expanding.
    if count > left / per_item {
        return Err(format!(
            "a cell claims {count} list items but only {left} bytes are left in the block"
        ));
    }
    list.clear();
    let mut next = 0u64;
    for _ in 0..count {
        let overflow = || format!("object rank out of range (the file has {n} objects)");
        let start = next
            .checked_add(read_varint(bytes, pos)?)
            .ok_or_else(overflow)?;
        let last = if mode < 2 {
            start
        } else {
            start.saturating_add(read_varint(bytes, pos)?)
        };
        if last >= u64::from(n) {
            return Err(format!(
                "object rank {last} is out of range (the file has {n} objects)"
            ));
        }
        list.extend(start as u32..=last as u32);
        next = last + if mode < 2 { 1 } else { 2 };
    }
    Ok((mode, back))
}

/// The sets of one block's cells as bitsets over the ranks, so that memory
/// is bounded by cells per block x objects / 8 whatever the lists hold.
pub struct BlockSets {
    words: usize,
    bits: Vec<u64>,
    cells: usize,
}

impl BlockSets {
    pub fn new(n: u32) -> Self {
        BlockSets {
            words: (n as usize).div_ceil(64),
            bits: Vec::new(),
            cells: 0,
        }
    }
    /// Forget the block's cells.
    pub fn clear(&mut self) {
        self.cells = 0;
    }
    /// How many cells of the block are decoded.
    pub fn len(&self) -> usize {
        self.cells
    }
    pub fn is_empty(&self) -> bool {
        self.cells == 0
    }
    /// Decode the next cell of the block; its set (ascending ranks) goes to `set`.
    pub fn decode_next(
        &mut self,
        bytes: &[u8],
        pos: &mut usize,
        n: u32,
        list: &mut Vec<u32>,
        set: &mut Vec<u32>,
    ) -> Result<u8, String> {
        let (mode, back) = decode_list(bytes, pos, n, self.cells, list)?;
        let w = self.words;
        let at = self.cells * w;
        if self.bits.len() < at + w {
            self.bits.resize(at + w, 0);
        }
        if back == 0 {
            self.bits[at..at + w].fill(0);
        } else {
            let from = (self.cells - back) * w;
            self.bits.copy_within(from..from + w, at);
        }
        let row = &mut self.bits[at..at + w];
        for &r in list.iter() {
            row[r as usize / 64] ^= 1 << (r % 64);
        }
        set.clear();
        for (k, &word) in row.iter().enumerate() {
            let mut word = word;
            while word != 0 {
                set.push((k * 64) as u32 + word.trailing_zeros());
                word &= word - 1;
            }
        }
        self.cells += 1;
        Ok(mode)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
    fn known_bytes() {
        // {1, 2, 3, 10} after {1, 2, 3}: difference {10} as gaps: head 1<<2|1, gap 10.
        let mut out = Vec::new();
        let mut diff = Vec::new();
        assert_eq!(
            encode_cell(&[vec![1, 2, 3]], &[1, 2, 3, 10], &mut diff, &mut out),
            MODE_DIFF_GAPS
        );
        assert_eq!(out, [0x05, 1, 10]);
        // {1, 2, 3} from nothing: one run as (gap 1, length-1 2), head 1<<2|2.
        out.clear();
        assert_eq!(
            encode_cell(&[], &[1, 2, 3], &mut diff, &mut out),
            MODE_SET_RUNS
        );
        assert_eq!(out, [0x06, 1, 2]);
    }

    proptest! {
        #[test]
        fn cells_round_trip(n in 1u32..3000, cells in proptest::collection::vec(proptest::collection::vec(any::<u32>(), 0..200), 1..8)) {
            let sets: Vec<Vec<u32>> = cells.iter().map(|c| {
                let mut s: Vec<u32> = c.iter().map(|v| v % n).collect();
                s.sort_unstable();
                s.dedup();
                s
            }).collect();
            let mut out = Vec::new();
            let mut diff = Vec::new();
            for k in 0..sets.len() {
                encode_cell(&sets[..k], &sets[k], &mut diff, &mut out);
            }
            let (mut pos, mut block, mut a, mut set) = (0, BlockSets::new(n), Vec::new(), Vec::new());
            for s in &sets {
                block.decode_next(&out, &mut pos, n, &mut a, &mut set).unwrap();
                prop_assert_eq!(&set, s);
            }
            prop_assert_eq!(pos, out.len());
        }

        #[test]
        fn arbitrary_bytes_never_panic(n in 0u32..100, bytes in proptest::collection::vec(any::<u8>(), 0..60)) {
            let (mut pos, mut block, mut a, mut set) = (0, BlockSets::new(n), Vec::new(), Vec::new());
            while pos < bytes.len() && block.len() < 64 {
                if block.decode_next(&bytes, &mut pos, n, &mut a, &mut set).is_err() {
                    break;
                }
                prop_assert!(set.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(set.iter().all(|&i| i < n));
            }
        }
    }
}
