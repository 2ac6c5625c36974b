//! The part file: a finished shard (`citypvs bake --shard K/N`) or a bake's
//! checkpoint (`OUTPUT.citypvs-checkpoint`). Both hold the same header (the
//! input's SHA-256, every bake setting, the tool version, the frame, the
//! object ids, K, N, the total cell count and the cell range with its
//! triangles) and the visible sets of a prefix of the range (all of it for a
//! finished shard), whole blocks already in the `.pvs` file's coding
//! ([`PartBuilder`] fills a part, [`write_parts`] writes the file of parts
//! that tile a bake). It is a sealed file (`super::sealed`: magic
//! "CPVSPART", the version, the payload's length and SHA-256, then the
//! payload; docs/scale-out.md), whose preamble is checked and whose payload
//! is decoded within a byte budget there; every field is then checked here.

use std::io::Write;

use bincode::{Decode, Encode};

use super::sealed::{decode_sealed, write_sealed};
use crate::error::{Error, Result};
use crate::input::Frame;
use crate::pvs::blocks::BlockEncoder;
use crate::pvs::{BLOCK_CELLS, BakeInfo, PvsWriter, WriteStats};
use crate::settings::{BakeNumbers, Settings};

/// The first eight bytes of every shard and checkpoint file.
pub const PART_MAGIC: [u8; 8] = *b"CPVSPART";
/// The part layout version this code writes and reads.
pub const PART_VERSION: u32 = 3;
/// What a part file is.
#[derive(Encode, Decode, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartKind {
    /// A finished shard: every cell of its range has its set.
    Shard,
    /// A bake's saved progress: a prefix of the range has its sets.
    Checkpoint,
}

/// Everything that decides a bake's result: two parts with equal keys (and
/// equal K, N and ranges) belong to the same bake.
#[derive(Encode, Decode, Clone, Debug)]
pub struct BakeKey {
    /// SHA-256 of the input file.
    pub source_hash: [u8; 32],
    /// Every bake number.
    pub numbers: BakeNumbers,
    /// [`Settings::region_hash`].
    pub region_hash: [u8; 32],
    /// The citypvs version that baked.
    pub tool_version: String,
}

impl BakeKey {
    /// The key of a bake of the input with hash `source_hash` under `settings`.
    pub fn of(source_hash: [u8; 32], settings: &Settings) -> BakeKey {
        BakeKey {
            source_hash,
            numbers: *settings.numbers(),
            region_hash: settings.region_hash(),
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// The names of the fields that differ (bit for bit), e.g. `["input", "eps"]`.
    pub fn differences(&self, other: &BakeKey) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.source_hash != other.source_hash {
            out.push("input");
        }
        out.extend(
            self.numbers
                .changed(&other.numbers)
                .into_iter()
                .map(|(name, _, _)| name),
        );
        if self.region_hash != other.region_hash {
            out.push("region");
        }
        if self.tool_version != other.tool_version {
            out.push("tool version");
        }
        out
    }
}

/// The input's frame, as stored in a part.
#[derive(Encode, Decode, Clone, Debug, PartialEq)]
pub enum FrameRecord {
    LonLat { lon0: f64, lat0: f64 },
    Metric { x: f64, y: f64, crs: Option<String> },
}

impl FrameRecord {
    pub fn of(frame: &Frame) -> FrameRecord {
        match frame {
            Frame::LonLat { lon0, lat0 } => FrameRecord::LonLat {
                lon0: *lon0,
                lat0: *lat0,
            },
            Frame::Metric { origin, crs } => FrameRecord::Metric {
                x: origin.x,
                y: origin.y,
                crs: crs.clone(),
            },
        }
    }

    pub fn to_frame(&self) -> Frame {
        match self {
            FrameRecord::LonLat { lon0, lat0 } => Frame::LonLat {
                lon0: *lon0,
                lat0: *lat0,
            },
            FrameRecord::Metric { x, y, crs } => Frame::Metric {
                origin: glam::DVec2::new(*x, *y),
                crs: crs.clone(),
            },
        }
    }
}

/// A shard or checkpoint, decoded.
#[derive(Encode, Decode, Clone, Debug)]
pub struct Part {
    pub kind: PartKind,
    pub key: BakeKey,
    pub frame: FrameRecord,
    /// K and N: this is shard K of N (a whole bake's checkpoint: 0 of 1).
    pub shard: u32,
    pub shards: u32,
    /// Cells of the whole bake.
    pub total_cells: u64,
    /// The range of cells (in cell order) this part covers.
    pub range_start: u64,
    pub range_end: u64,
    /// Object ids of the whole bake, index = object index.
    pub object_ids: Vec<String>,
    /// The objects' fingerprints (`crate::pvs::prints`), one per object.
    pub object_prints: Vec<crate::pvs::prints::ObjectPrint>,
    /// The triangles of the range's cells: x0 y0 x1 y1 x2 y2 in local metres.
    pub cells: Vec<[f64; 6]>,
    /// The visible sets of the first [`Part::done`] cells of the range.
    /// Those in whole blocks of the `.pvs` file (docs/FORMAT.md, "Blocks":
    /// [`BLOCK_CELLS`] cells from a multiple of it, the last block ending
    /// at the last cell) that lie inside the range are kept as the file's
    /// block bytes, in its spatial numbering of the objects (from
    /// `object_prints`): `block_lens` gives each block's bytes in `blocks`.
    pub block_lens: Vec<u32>,
    pub blocks: Vec<u8>,
    /// The other cells' sets: the head (the cells before the range's first
    /// block boundary, whose block starts in the shard before) and the tail
    /// (the cells after the last whole block: the start of a block that
    /// ends in the next shard, or the cells done so far of a checkpoint's
    /// open block). Each set is its runs of consecutive indices, each as two
    /// LEB128 numbers (the run's start minus the end of the run before, or
    /// minus 0 for the first; the run's length minus 1); `loose_lens` gives
    /// each set's bytes in `loose_runs`. A cell that sees every object
    /// takes two bytes.
    pub loose_lens: Vec<u32>,
    pub loose_runs: Vec<u8>,
}

fn push_leb128(out: &mut Vec<u8>, v: u32) {
    crate::pvs::codec::write_leb128(out, u64::from(v));
}

/// One LEB128 number of at most 32 bits from `bytes` at `*at`.
fn read_leb128(bytes: &[u8], at: &mut usize) -> Option<u32> {
    crate::pvs::codec::read_leb128_u32(bytes, at).ok()
}

/// Decode one set's run bytes, calling `f` with each member; `None` when
/// the bytes are malformed or a member would pass `u32::MAX`.
fn decode_runs(bytes: &[u8], mut f: impl FnMut(u32)) -> Option<()> {
    let (mut at, mut end) = (0usize, 0u64);
    while at < bytes.len() {
        let start = end + u64::from(read_leb128(bytes, &mut at)?);
        let len = u64::from(read_leb128(bytes, &mut at)?) + 1;
        if start + len > u64::from(u32::MAX) {
            return None;
        }
        for o in start..start + len {
            f(o as u32);
        }
        end = start + len;
    }
    Some(())
}

/// The sets in the run form a part stores (ascending indices each).
pub fn pack_sets<'a>(sets: impl IntoIterator<Item = &'a [u32]>) -> (Vec<u32>, Vec<u8>) {
    let (mut lens, mut runs) = (Vec::new(), Vec::new());
    for set in sets {
        let before = runs.len();
        let mut end = 0u32;
        let mut i = 0;
        while i < set.len() {
            let start = set[i];
            let mut j = i + 1;
            while j < set.len() && set[j] == set[j - 1] + 1 {
                j += 1;
            }
            push_leb128(&mut runs, start - end);
            push_leb128(&mut runs, (j - i - 1) as u32);
            end = set[j - 1] + 1;
            i = j;
        }
        lens.push((runs.len() - before) as u32);
    }
    (lens, runs)
}

impl Part {
    /// The cells of the range.
    pub fn range_len(&self) -> usize {
        (self.range_end - self.range_start) as usize
    }

    /// Cells of the range that have their sets.
    pub fn done(&self) -> usize {
        let loose = self.loose_lens.len();
        if self.block_lens.is_empty() {
            return loose;
        }
        let start = self.blocks_start();
        let in_blocks = (self.block_lens.len() as u64 * u64::from(BLOCK_CELLS))
            .min(self.total_cells.saturating_sub(start));
        loose + in_blocks as usize
    }

    /// The head's length: the cells of the range before its first block
    /// boundary (all of it when the range lies inside one block).
    pub fn head_len(&self) -> usize {
        let b = u64::from(BLOCK_CELLS);
        let boundary = self.range_start.div_ceil(b) * b;
        (boundary.min(self.range_end) - self.range_start) as usize
    }

    /// The first cell of the range's whole blocks.
    fn blocks_start(&self) -> u64 {
        self.range_start + self.head_len() as u64
    }

    /// Cells of the file's block that starts at cell `start` (a multiple
    /// of [`BLOCK_CELLS`]).
    fn block_cells_at(&self, start: u64) -> u64 {
        (u64::from(BLOCK_CELLS)).min(self.total_cells - start)
    }

    /// Hand the stored sets to `f` in cell order: the loose ones decoded
    /// (ascending object indices), a whole block as its bytes.
    fn for_each_piece(&self, f: &mut dyn FnMut(Piece) -> Result<()>) -> Result<()> {
        let head = self.head_len().min(self.loose_lens.len());
        let mut at = 0;
        let mut set = Vec::new();
        let mut loose = |lens: &[u32], f: &mut dyn FnMut(Piece) -> Result<()>| {
            for &len in lens {
                set.clear();
                let bytes = &self.loose_runs[at..at + len as usize];
                decode_runs(bytes, |o| set.push(o))
                    .ok_or_else(|| Error::format("a stored visible set is malformed"))?;
                at += len as usize;
                f(Piece::Set(&set))?;
            }
            Ok(())
        };
        loose(&self.loose_lens[..head], f)?;
        let (mut start, mut byte) = (self.blocks_start(), 0usize);
        for &len in &self.block_lens {
            let cells = self.block_cells_at(start);
            f(Piece::Block(
                &self.blocks[byte..byte + len as usize],
                (start / u64::from(BLOCK_CELLS)) as usize,
                cells as usize,
            ))?;
            start += cells;
            byte += len as usize;
        }
        loose(&self.loose_lens[head..], f)
    }

    /// Hand the stored sets (ascending object indices) to `f` one at a
    /// time, in cell order, without expanding them all (one block is
    /// decoded at a time).
    pub fn for_each_set(&self, f: &mut dyn FnMut(&[u32]) -> Result<()>) -> Result<()> {
        let n = self.object_ids.len() as u32;
        let input_of_rank = crate::pvs::object_ranks(&self.object_prints, Vec::new());
        let (mut marks, mut visible) = (Vec::new(), Vec::new());
        self.for_each_piece(&mut |piece| match piece {
            Piece::Set(set) => f(set),
            Piece::Block(bytes, block, cells) => crate::pvs::decode_block(
                bytes,
                n,
                BLOCK_CELLS as usize,
                block,
                cells - 1,
                true,
                |_, ranks, _| {
                    crate::pvs::ranks_to_input(ranks, &input_of_rank, &mut marks, &mut visible);
                    f(&visible)
                },
            ),
        })
    }

    /// Write the `.pvs` file of a part that covers every cell of its bake
    /// (a whole bake's, not a shard's): [`write_parts`] of it alone.
    pub fn write_pvs(&self, path: &std::path::Path) -> Result<WriteStats> {
        write_parts(path, self, &[self])
    }

    /// Push the stored sets into `w`, which is at this part's first cell:
    /// whole blocks as they are (the writer decodes and checks them), the
    /// others one set at a time.
    fn write_into(&self, w: &mut PvsWriter) -> Result<()> {
        self.for_each_piece(&mut |piece| match piece {
            Piece::Set(set) => w.push_cell(set),
            Piece::Block(bytes, _, _) => w.push_block(bytes),
        })
        .map_err(|e| e.context(format!("shard {} of {}", self.shard, self.shards)))
    }

    /// The stored sets, ascending object indices (checked when decoded).
    pub fn sets(&self) -> Vec<Vec<u32>> {
        let mut out = Vec::with_capacity(self.done());
        self.for_each_set(&mut |s| {
            out.push(s.to_vec());
            Ok(())
        })
        .expect("sets are checked when decoded or coded by PartBuilder");
        out
    }

    /// Keep only the sets of the first `cells` cells.
    pub fn truncate_sets(&mut self, cells: usize) -> Result<()> {
        let mut sets = Vec::with_capacity(cells);
        self.for_each_set(&mut |s| {
            if sets.len() < cells {
                sets.push(s.to_vec());
            }
            Ok(())
        })?;
        for v in [&mut self.block_lens, &mut self.loose_lens] {
            v.clear();
        }
        for v in [&mut self.blocks, &mut self.loose_runs] {
            v.clear();
        }
        let mut builder = PartBuilder::new(self.clone())?;
        for set in &sets {
            builder.push(set);
        }
        *self = builder.into_part();
        Ok(())
    }

    /// The triangles of the range's cells.
    pub fn triangles(&self) -> Vec<[glam::DVec2; 3]> {
        use glam::DVec2;
        self.cells
            .iter()
            .map(|c| {
                [
                    DVec2::new(c[0], c[1]),
                    DVec2::new(c[2], c[3]),
                    DVec2::new(c[4], c[5]),
                ]
            })
            .collect()
    }

    /// The `.pvs` header of the bake this part belongs to.
    pub fn bake_info(&self) -> BakeInfo {
        BakeInfo {
            numbers: self.key.numbers,
            frame: self.frame.to_frame(),
            source_hash: self.key.source_hash,
            region_hash: self.key.region_hash,
            tool_version: self.key.tool_version.clone(),
        }
    }

    /// Whether `other` is a part of the same bake, over the same range, in
    /// the same frame with the same objects and cells: a checkpoint is only
    /// used when this holds. `None` when it does, else what differs.
    pub fn mismatch(&self, other: &Part) -> Option<String> {
        let keys = self.key.differences(&other.key);
        if !keys.is_empty() {
            return Some(keys.join(", "));
        }
        let mut out = Vec::new();
        if (self.shard, self.shards) != (other.shard, other.shards) {
            out.push("shard");
        }
        if (self.total_cells, self.range_start, self.range_end)
            != (other.total_cells, other.range_start, other.range_end)
        {
            out.push("cell range");
        }
        if self.frame != other.frame {
            out.push("frame");
        }
        if self.object_ids != other.object_ids || self.object_prints != other.object_prints {
            out.push("objects");
        }
        let bits = |c: &[[f64; 6]]| -> Vec<u64> {
            c.iter()
                .flat_map(|t| t.iter().map(|v| v.to_bits()))
                .collect()
        };
        if bits(&self.cells) != bits(&other.cells) {
            out.push("cells");
        }
        (!out.is_empty()).then(|| out.join(", "))
    }

    /// The file's bytes.
    pub fn encode(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        self.write_to(&mut out)
            .map_err(|e| Error::format(format!("cannot encode a part file: {e}")))?;
        Ok(out)
    }

    /// Write the file's bytes to `out` in two passes (one to learn the
    /// payload's length and digest for the preamble, one to write it), so
    /// that no copy of the sets is held beside the part.
    fn write_to(&self, out: &mut dyn Write) -> std::io::Result<()> {
        write_sealed(out, &PART_MAGIC, PART_VERSION, self)
    }

    /// Write the file atomically (see `Part::write_to`).
    pub fn write(&self, path: &std::path::Path) -> Result<()> {
        crate::atomic::write_atomically_with(path, &mut |w| {
            let mut w = std::io::BufWriter::new(w);
            self.write_to(&mut w)?;
            w.flush()
        })
    }

    /// Read and check a part file; errors start with the file's name.
    pub fn read(path: &std::path::Path) -> Result<Part> {
        let starts_right = |b: &[u8]| b.starts_with(&PART_MAGIC);
        let bytes = crate::infile::read_whole(path, starts_right, "a shard or checkpoint file")?;
        Part::decode(&bytes).map_err(|e| e.context(path.display()))
    }

    /// Decode and check a part file's bytes.
    pub fn decode(bytes: &[u8]) -> Result<Part> {
        let part: Part = decode_sealed(
            bytes,
            &PART_MAGIC,
            PART_VERSION,
            "a citypvs shard or checkpoint file",
        )?;
        part.check()?;
        Ok(part)
    }

    /// Check every field for consistency.
    fn check(&self) -> Result<()> {
        let bad = |m: String| Err(Error::format(format!("invalid payload: {m}")));
        if self.shards == 0 || self.shard >= self.shards {
            return bad(format!("shard {} of {}", self.shard, self.shards));
        }
        if !(self.range_start <= self.range_end && self.range_end <= self.total_cells) {
            return bad(format!(
                "cell range {}..{} of {} cells",
                self.range_start, self.range_end, self.total_cells
            ));
        }
        let n = self.range_len();
        if self.cells.len() != n {
            return bad(format!(
                "{} cell triangles for a range of {n} cells",
                self.cells.len()
            ));
        }
        if !self.object_prints.is_empty() && self.object_prints.len() != self.object_ids.len() {
            return bad(format!(
                "{} object fingerprints for {} objects",
                self.object_prints.len(),
                self.object_ids.len()
            ));
        }
        if self.cells.iter().flatten().any(|v| !v.is_finite()) {
            return bad("a cell triangle has a non-finite coordinate".into());
        }
        if !self.object_ids.is_empty() && self.object_prints.len() != self.object_ids.len() {
            return bad("no object fingerprints, which number the objects in the blocks".into());
        }
        if let Some(k) = self
            .object_prints
            .iter()
            .position(|p| !crate::pvs::prints::rect_storable(&p.rect))
        {
            return bad(format!(
                "object {k}'s fingerprint rectangle cannot be stored"
            ));
        }
        let head = self.head_len();
        let loose = self.loose_lens.len();
        let blocks = self.block_lens.len() as u64;
        if blocks > 0 && loose < head {
            return bad(format!(
                "{blocks} blocks after only {loose} of the {head} cells before the first block"
            ));
        }
        // The whole blocks inside the range: those of BLOCK_CELLS cells,
        // and the short last block of the bake when the range ends there.
        let b = u64::from(BLOCK_CELLS);
        let start = self.blocks_start();
        let rest = self.range_end - start;
        let short_last = self.range_end == self.total_cells && !rest.is_multiple_of(b);
        let whole = rest / b + u64::from(short_last);
        if blocks > whole {
            return bad(format!("{blocks} blocks in a range that holds {whole}"));
        }
        let done = self.done();
        let tail = loose.saturating_sub(head) as u64;
        let open = start + blocks * b;
        if tail > 0 && (open >= self.total_cells || tail >= self.block_cells_at(open)) {
            return bad(format!("{tail} cells after the last whole block"));
        }
        if done > n || (self.kind == PartKind::Shard && done != n) {
            return bad(format!("{done} visible sets for a range of {n} cells"));
        }
        let total: u64 = self.block_lens.iter().map(|&l| l as u64).sum();
        if total != self.blocks.len() as u64 {
            return bad(format!(
                "the block lengths add up to {total} bytes, but {} are stored",
                self.blocks.len()
            ));
        }
        let total: u64 = self.loose_lens.iter().map(|&l| l as u64).sum();
        if total != self.loose_runs.len() as u64 {
            return bad(format!(
                "the set lengths add up to {total} bytes, but {} are stored",
                self.loose_runs.len()
            ));
        }
        let objects = self.object_ids.len() as u64;
        let mut at = 0;
        for (c, &len) in self.loose_lens.iter().enumerate() {
            let in_blocks = if c < head { 0 } else { (done - loose) as u64 };
            let cell = self.range_start + c as u64 + in_blocks;
            let mut top = None;
            let bytes = &self.loose_runs[at..at + len as usize];
            // Members only ever grow, so checking the last one of each run
            // suffices; stop at the first one out of range.
            let mut at_run = 0usize;
            let mut end = 0u64;
            while at_run < bytes.len() {
                let (Some(gap), Some(more)) = (
                    read_leb128(bytes, &mut at_run),
                    read_leb128(bytes, &mut at_run),
                ) else {
                    return bad(format!("the set of cell {cell} is malformed"));
                };
                let last = end + u64::from(gap) + u64::from(more);
                if last >= objects {
                    top = Some(last);
                    break;
                }
                end = last + 1;
            }
            if let Some(o) = top {
                return bad(format!(
                    "the set of cell {cell} holds object {o}, but there are {objects} objects"
                ));
            }
            at += len as usize;
        }
        Ok(())
    }
}

/// A stretch of a part's stored sets.
enum Piece<'a> {
    /// One cell's set, ascending object indices.
    Set(&'a [u32]),
    /// A whole block's bytes, its number in the file and its number of
    /// cells.
    Block(&'a [u8], usize, usize),
}

/// Write the `.pvs` file of the cells of `parts`, which tile the bake's
/// cells in order (a whole bake's one part, or a merge's shards), to
/// `path` atomically; the header, the object ids and fingerprints are
/// those of `head` (a part of the same bake: a merge keeps them in one
/// shard only). The whole blocks are copied (after the writer has
/// decoded them: a damaged one is refused); the cells of the blocks that
/// straddle two parts are coded here, so the file is byte for byte the one
/// a writer given every set writes.
pub fn write_parts(path: &std::path::Path, head: &Part, parts: &[&Part]) -> Result<WriteStats> {
    let (bytes, stats) = encode_parts(head, parts).map_err(|e| e.context(path.display()))?;
    crate::atomic::write_atomically(path, &bytes)?;
    Ok(stats)
}

/// The bytes [`write_parts`] writes.
pub fn encode_parts(head: &Part, parts: &[&Part]) -> Result<(Vec<u8>, WriteStats)> {
    let mut w = PvsWriter::with_prints(
        head.bake_info(),
        head.object_ids.clone(),
        head.object_prints.clone(),
        Vec::new(),
        parts.iter().flat_map(|p| p.triangles()).collect(),
    )?;
    for part in parts {
        part.write_into(&mut w)?;
    }
    w.finish()
}

/// Adds finished cells' sets to a part in cell order, coding each whole
/// block of the `.pvs` file as soon as its last cell comes: what a bake
/// holds of its finished cells is then about the size of the file's
/// blocks, not of the sets (docs/DESIGN.md, "Finished cells").
pub struct PartBuilder {
    part: Part,
    numbering: Numbering,
    /// The open block's cells (the part's tail), coded so far.
    block: BlockEncoder,
    ranks: Vec<u32>,
}

/// The file's spatial numbering of the objects, in which blocks code their
/// sets.
#[derive(Clone)]
pub struct Numbering {
    /// Spatial rank of each object index.
    rank_of: Vec<u32>,
}

impl Numbering {
    /// Whether this is the numbering that gives each rank the input index
    /// `input_of_rank[rank]` (a file's): then a block of that file holds
    /// the bytes [`Numbering::code_block`] gives for the same sets (a
    /// block's bytes depend only on its cells' sets in the numbering).
    pub fn is(&self, input_of_rank: &[u32]) -> bool {
        input_of_rank.len() == self.rank_of.len()
            && input_of_rank
                .iter()
                .enumerate()
                .all(|(rank, &i)| self.rank_of.get(i as usize) == Some(&(rank as u32)))
    }

    /// The bytes of a whole block of `sets` (ascending object indices):
    /// what [`PartBuilder::push`] codes for them when they fill a block.
    pub fn code_block<'s>(&self, sets: impl Iterator<Item = &'s [u32]>) -> Vec<u8> {
        let mut block = BlockEncoder::new(self.rank_of.len() as u32, BLOCK_CELLS);
        let mut ranks = Vec::new();
        for set in sets {
            self.code(set, &mut block, &mut ranks);
        }
        block.finish()
    }

    /// Code one cell's set into `block` (`ranks` is scratch).
    fn code(&self, set: &[u32], block: &mut BlockEncoder, ranks: &mut Vec<u32>) {
        crate::pvs::set_ranks(set, &self.rank_of, ranks);
        block.push(ranks);
    }
}

impl PartBuilder {
    /// Go on filling `part` (empty, or a checkpoint's prefix).
    pub fn new(part: Part) -> Result<PartBuilder> {
        let n = part.object_ids.len();
        if n > 0 && part.object_prints.len() != n {
            return Err(Error::format(
                "a part's sets are coded in the file's numbering, which needs every object's fingerprint",
            ));
        }
        let rank_of =
            crate::pvs::rank_of_input(&crate::pvs::object_ranks(&part.object_prints, Vec::new()));
        let mut builder = PartBuilder {
            block: BlockEncoder::new(n as u32, BLOCK_CELLS),
            part,
            numbering: Numbering { rank_of },
            ranks: Vec::new(),
        };
        // The tail's cells were coded into the open block before the
        // checkpoint was saved; code them again (a block's bytes depend only
        // on its cells' sets). The loose sets after the head are the tail.
        let head = builder.part.head_len();
        let mut tail = Vec::new();
        let mut loose = 0;
        builder.part.for_each_piece(&mut |piece| {
            if let Piece::Set(set) = piece {
                if loose >= head {
                    tail.push(set.to_vec());
                }
                loose += 1;
            }
            Ok(())
        })?;
        for set in &tail {
            builder.code(set);
        }
        Ok(builder)
    }

    /// The part as it stands (to save it as a checkpoint).
    pub fn part(&self) -> &Part {
        &self.part
    }

    /// The part, with every set pushed so far.
    pub fn into_part(self) -> Part {
        self.part
    }

    /// Add the set (ascending object indices) of the range's next cell.
    pub fn push(&mut self, set: &[u32]) {
        let p = &mut self.part;
        let k = p.done();
        assert!(k < p.range_len(), "more sets than the range's cells");
        let (lens, runs) = pack_sets(std::iter::once(set));
        p.loose_lens.extend(lens);
        p.loose_runs.extend(runs);
        if k < p.head_len() {
            return;
        }
        self.code(set);
        let cell = self.part.range_start + k as u64 + 1;
        if cell.is_multiple_of(u64::from(BLOCK_CELLS)) || cell == self.part.total_cells {
            let bytes = self.block.finish();
            let p = &mut self.part;
            let head = p.head_len();
            let keep: usize = p.loose_lens[..head].iter().map(|&l| l as usize).sum();
            p.loose_lens.truncate(head);
            p.loose_runs.truncate(keep);
            p.block_lens.push(bytes.len() as u32);
            p.blocks.extend_from_slice(&bytes);
        }
    }

    /// Add the range's next `cells` cells as one whole block already coded
    /// in this builder's numbering ([`PartBuilder::numbering`]): they
    /// must start a block of the file and fill it, or end the bake.
    pub fn push_coded_block(&mut self, cells: usize, bytes: &[u8]) {
        let p = &mut self.part;
        let k = p.done();
        let (start, end) = (p.range_start + k as u64, p.range_start + (k + cells) as u64);
        let block = u64::from(BLOCK_CELLS);
        assert!(
            k >= p.head_len() && p.loose_lens.len() == p.head_len(),
            "a coded block cannot follow cells of an open block"
        );
        assert!(
            start.is_multiple_of(block)
                && cells > 0
                && end <= p.range_end
                && (end - start == block || end == p.total_cells),
            "a coded block must be a whole block of the file"
        );
        p.block_lens.push(bytes.len() as u32);
        p.blocks.extend_from_slice(bytes);
    }

    /// The numbering the sets are coded in.
    pub fn numbering(&self) -> &Numbering {
        &self.numbering
    }

    /// Code a tail cell's set into the open block.
    fn code(&mut self, set: &[u32]) {
        self.numbering.code(set, &mut self.block, &mut self.ranks);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A part of shard `k` of `n` over `range` of `total` cells, with
    /// `objects` objects and no sets.
    fn blank(total: u64, range: std::ops::Range<u64>, objects: u32, k: u32, n: u32) -> Part {
        Part {
            kind: PartKind::Shard,
            key: BakeKey::of([7; 32], &Settings::default()),
            frame: FrameRecord::LonLat {
                lon0: 24.9,
                lat0: 60.1,
            },
            shard: k,
            shards: n,
            total_cells: total,
            range_start: range.start,
            range_end: range.end,
            object_ids: (0..objects).map(|i| format!("b{i}")).collect(),
            object_prints: (0..objects)
                .map(|i| {
                    let (x, y) = (f64::from(i * 37 % 101) * 3.0, f64::from(i * 11 % 53) * 2.0);
                    crate::pvs::prints::ObjectPrint {
                        object: u64::from(i) + 1,
                        block: 0,
                        rect: [x, y, x + 5.0, y + 4.0],
                    }
                })
                .collect(),
            cells: range
                .map(|c| {
                    let x = c as f64;
                    [x, 0.0, x + 1.0, 0.0, x, 1.0]
                })
                .collect(),
            block_lens: Vec::new(),
            blocks: Vec::new(),
            loose_lens: Vec::new(),
            loose_runs: Vec::new(),
        }
    }

    /// `blank` filled with `sets` by a [`PartBuilder`].
    fn filled(blank: Part, sets: &[Vec<u32>]) -> Part {
        let mut b = PartBuilder::new(blank).unwrap();
        for s in sets {
            b.push(s);
        }
        b.into_part()
    }

    /// Sets of `cells` cells over `objects` objects, changing slowly from
    /// cell to cell as neighbouring cells' sets do.
    fn some_sets(cells: u64, objects: u32) -> Vec<Vec<u32>> {
        (0..cells)
            .map(|c| {
                (0..objects)
                    .filter(|&o| (u64::from(o) * 7 + c / 5 + (c * u64::from(o)) / 97) % 5 < 2)
                    .collect()
            })
            .collect()
    }

    fn part() -> Part {
        filled(blank(9, 3..6, 6, 1, 3), &[vec![0, 2, 5], vec![], vec![1]])
    }

    #[test]
    fn a_part_reads_back_with_its_sets() {
        let p = part();
        let q = Part::decode(&p.encode().unwrap()).unwrap();
        assert_eq!(q.sets(), vec![vec![0, 2, 5], vec![], vec![1]]);
        assert_eq!(p.mismatch(&q), None);
    }

    #[test]
    fn a_written_part_file_holds_exactly_the_encoded_bytes() {
        let p = part();
        let dir = std::env::temp_dir().join(format!("citypvs-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.part");
        p.write(&path).unwrap();
        let written = std::fs::read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(written, p.encode().unwrap());
        assert_eq!(Part::decode(&written).unwrap().sets(), p.sets());
    }

    #[test]
    fn truncation_corruption_and_bad_fields_are_refused() {
        let bytes = part().encode().unwrap();
        for cut in [0, 5, 30, bytes.len() - 1] {
            let err = Part::decode(&bytes[..cut]).unwrap_err();
            assert_eq!(err.kind(), &crate::ErrorKind::Format, "{err}");
        }
        let err = Part::decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(err.to_string().contains("truncated"), "{err}");
        let mut flipped = bytes.clone();
        *flipped.last_mut().unwrap() ^= 1;
        let err = Part::decode(&flipped).unwrap_err();
        assert!(err.to_string().contains("corrupted"), "{err}");
        // A well-formed file with an object index out of range.
        let mut p = part();
        p.loose_runs[2] = 9;
        let err = Part::decode(&p.encode().unwrap()).unwrap_err();
        assert!(err.to_string().contains("holds object"), "{err}");
        // A fingerprint rectangle the file could not store.
        for (at, bad) in [(2, f64::NAN), (2, 1e300), (0, -1e300), (2, -1.0)] {
            let mut p = part();
            p.object_prints[2].rect[at] = bad;
            let err = Part::decode(&p.encode().unwrap()).unwrap_err();
            assert!(err.to_string().contains("rectangle"), "{bad}: {err}");
        }
    }

    #[test]
    fn a_hostile_length_prefix_hits_the_limit_not_the_allocator() {
        // A valid preamble and checksum over a payload that claims 2^40 ids.
        let mut payload =
            bincode::encode_to_vec(PartKind::Shard, bincode::config::standard()).unwrap();
        let key = BakeKey::of([0; 32], &Settings::default());
        payload.extend(bincode::encode_to_vec(&key, bincode::config::standard()).unwrap());
        payload.extend(
            bincode::encode_to_vec(
                FrameRecord::LonLat {
                    lon0: 0.0,
                    lat0: 0.0,
                },
                bincode::config::standard(),
            )
            .unwrap(),
        );
        for v in [0u64, 1, 1, 0, 1] {
            payload.extend(bincode::encode_to_vec(v, bincode::config::standard()).unwrap());
        }
        payload.extend(bincode::encode_to_vec(1u64 << 40, bincode::config::standard()).unwrap());
        let bytes = crate::scale::sealed::seal(&PART_MAGIC, PART_VERSION, &payload);
        let err = Part::decode(&bytes).unwrap_err();
        assert_eq!(err.kind(), &crate::ErrorKind::Format, "{err}");
        assert!(err.to_string().contains("LimitExceeded"), "{err}");
    }

    #[test]
    fn parts_with_whole_blocks_write_the_file_of_one_writer() {
        let (total, objects) = (1300u64, 90u32);
        let sets = some_sets(total, objects);
        let cells: Vec<[glam::DVec2; 3]> = blank(total, 0..total, objects, 0, 1).triangles();
        let whole = blank(total, 0..total, objects, 0, 1);
        let data = crate::pvs::PvsData {
            info: whole.bake_info(),
            object_ids: whole.object_ids.clone(),
            object_prints: whole.object_prints.clone(),
            cells,
            visible: sets.clone(),
        };
        let (expected, _) = crate::pvs::encode_pvs(&data).unwrap();
        let dir = tempfile::tempdir().unwrap();
        // One part; shards whose borders fall inside blocks, on a block
        // boundary, and inside the short last block.
        for bounds in [
            vec![0, 1300],
            vec![0, 300, 1100, 1300],
            vec![0, 512, 1024, 1300],
            vec![0, 1030, 1040, 1300],
            vec![0, 10, 20, 1300],
        ] {
            let n = bounds.len() as u32 - 1;
            let parts: Vec<Part> = bounds
                .windows(2)
                .enumerate()
                .map(|(k, w)| {
                    let p = filled(
                        blank(total, w[0]..w[1], objects, k as u32, n),
                        &sets[w[0] as usize..w[1] as usize],
                    );
                    // Read back from its bytes, with the same sets.
                    let q = Part::decode(&p.encode().unwrap()).unwrap();
                    assert_eq!(q.sets(), sets[w[0] as usize..w[1] as usize], "{bounds:?}");
                    q
                })
                .collect();
            assert!(parts.iter().map(|p| p.block_lens.len()).sum::<usize>() > 0);
            let path = dir.path().join("out.pvs");
            let refs: Vec<&Part> = parts.iter().collect();
            write_parts(&path, refs[0], &refs).unwrap();
            assert!(std::fs::read(&path).unwrap() == expected, "{bounds:?}");
        }
    }

    #[test]
    fn whole_blocks_coded_apart_or_copied_from_a_file_make_the_same_part() {
        let (total, objects) = (1300u64, 90u32);
        let sets = some_sets(total, objects);
        let mut by_cell = PartBuilder::new(blank(total, 0..total, objects, 0, 1)).unwrap();
        for set in &sets {
            by_cell.push(set);
        }
        let by_cell = by_cell.into_part();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pvs");
        write_parts(&path, &by_cell, &[&by_cell]).unwrap();
        let file = crate::pvs::PvsReader::open(&path).unwrap();
        let mut by_block = PartBuilder::new(blank(total, 0..total, objects, 0, 1)).unwrap();
        assert!(by_block.numbering().is(file.input_of_rank()));
        let mut reversed = file.input_of_rank().to_vec();
        reversed.reverse();
        assert!(!by_block.numbering().is(&reversed));
        // The first block from the file's bytes, the others coded here.
        let block = BLOCK_CELLS as usize;
        by_block.push_coded_block(block, file.coded_block(0));
        assert_eq!(
            file.block_set_lens(0).unwrap(),
            sets[..block].iter().map(Vec::len).collect::<Vec<_>>()
        );
        for range in [block..2 * block, 2 * block..total as usize] {
            let numbering = by_block.numbering().clone();
            let bytes = numbering.code_block(sets[range.clone()].iter().map(Vec::as_slice));
            by_block.push_coded_block(range.len(), &bytes);
        }
        let by_block = by_block.into_part();
        assert_eq!(by_block.done(), total as usize);
        assert!(by_block.blocks == by_cell.blocks && by_block.block_lens == by_cell.block_lens);
        assert_eq!(by_block.sets(), sets);
    }

    #[test]
    fn a_checkpoint_goes_on_to_the_same_part() {
        let (total, objects) = (1300u64, 50u32);
        let sets = some_sets(total, objects);
        let range = 300..1100;
        let full = filled(blank(total, range.clone(), objects, 1, 3), &sets[300..1100]);
        // Cut inside the head, inside the block, just after it, in the tail.
        for done in [0usize, 100, 212, 500, 724, 730, 799] {
            let mut cp = full.clone();
            cp.kind = PartKind::Checkpoint;
            cp.truncate_sets(done).unwrap();
            let cp = Part::decode(&cp.encode().unwrap()).unwrap();
            assert_eq!(cp.done(), done);
            assert_eq!(cp.sets(), sets[300..300 + done]);
            let mut b = PartBuilder::new(cp).unwrap();
            for s in &sets[300 + done..1100] {
                b.push(s);
            }
            let mut resumed = b.into_part();
            resumed.kind = PartKind::Shard;
            assert_eq!(resumed.encode().unwrap(), full.encode().unwrap(), "{done}");
        }
    }

    #[test]
    fn a_damaged_block_is_refused_when_written() {
        let (total, objects) = (1300u64, 50u32);
        let sets = some_sets(total, objects);
        let mut p = filled(blank(total, 0..total, objects, 0, 1), &sets);
        let cut = 3;
        let len = p.block_lens[0] as usize;
        p.blocks.drain(len - cut..len);
        p.block_lens[0] -= cut as u32;
        // The lengths agree, so the part reads; its block does not decode.
        let p = Part::decode(&p.encode().unwrap()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.pvs");
        let err = write_parts(&path, &p, &[&p]).unwrap_err();
        assert!(err.to_string().contains("out.pvs"), "{err}");
        assert!(!path.exists());
        // A tail as long as its block is not a part this code writes.
        let mut q = filled(blank(total, 0..1100, objects, 0, 2), &sets[..1100]);
        q.kind = PartKind::Checkpoint;
        q.truncate_sets(1000).unwrap();
        let (lens, runs) = pack_sets(sets[1000..1024].iter().map(|s| s.as_slice()));
        q.loose_lens.extend(lens);
        q.loose_runs.extend(runs);
        let err = Part::decode(&q.encode().unwrap()).unwrap_err();
        assert!(
            err.to_string().contains("after the last whole block"),
            "{err}"
        );
    }
}
