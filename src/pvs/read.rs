//! Reading and validating a version 3 `.pvs` file (docs/FORMAT.md). At open:
//! the header (every number checked once), the section lengths, the object
//! table, the vertex table, the triangles and the block index, each parsed
//! within the bytes of its own section, so no count taken from the file can
//! make the reader allocate more than that section justifies. Visible sets
//! are decoded only when asked for, one block at most per cell.

use std::path::Path;

use glam::DVec2;

use super::prints::ObjectPrint;
use sha2::{Digest, Sha256};

use super::blocks::{BlockDecoder, read_varint};
use super::grid::CellGrid;
use super::{BakeInfo, FORMAT_VERSION, HEADER_BYTES, MAGIC, MAX_BLOCK_CELLS, SECTION_NAMES};
use crate::BakeNumbers;
use crate::frame::Frame;
use crate::{Error, Result};

/// Reads a `.pvs` file; each cell's visible set is decoded on demand.
pub struct PvsReader {
    bytes: Vec<u8>,
    parsed: Parsed,
    grid: CellGrid,
}

/// A little-endian reader over the bytes of one section (or of a whole
/// old-layout file), naming the section in its errors.
pub(super) struct Cursor<'a> {
    bytes: &'a [u8],
    pub(super) pos: usize,
    section: &'static str,
}

impl<'a> Cursor<'a> {
    pub(super) fn new(bytes: &'a [u8], section: &'static str) -> Self {
        Cursor::at(bytes, 0, section)
    }
    pub(super) fn at(bytes: &'a [u8], pos: usize, section: &'static str) -> Self {
        Cursor {
            bytes,
            pos: pos.min(bytes.len()),
            section,
        }
    }
    pub(super) fn left(&self) -> usize {
        self.bytes.len() - self.pos
    }
    pub(super) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if n > self.left() {
            return Err(Error::format(format!(
                "{what} runs past the end of the {} section",
                self.section
            )));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    pub(super) fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    pub(super) fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    pub(super) fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn varint(&mut self, what: &str) -> Result<u64> {
        read_varint(self.bytes, &mut self.pos)
            .map_err(|e| Error::format(format!("{what} in the {} section: {e}", self.section)))
    }
    fn string(&mut self, what: &str) -> Result<&'a str> {
        let len = self.varint(what)?;
        if len > self.left() as u64 {
            return Err(Error::format(format!(
                "{what} of {len} bytes runs past the end of the {} section",
                self.section
            )));
        }
        let raw = self.take(len as usize, what)?;
        std::str::from_utf8(raw).map_err(|_| Error::format(format!("{what} is not valid UTF-8")))
    }
    fn done(&self) -> Result<()> {
        if self.left() != 0 {
            return Err(Error::format(format!(
                "the {} section has {} bytes left over",
                self.section,
                self.left()
            )));
        }
        Ok(())
    }
}

impl PvsReader {
    /// Open and validate the header and tables.
    pub fn open(path: &Path) -> Result<PvsReader> {
        let bytes = crate::infile::read_whole(path, |b| b.starts_with(&MAGIC), "a .pvs file")?;
        PvsReader::from_bytes(bytes).map_err(|e| e.context(path.display()))
    }

    /// Validate and index a whole file held in memory.
    pub fn from_bytes(bytes: Vec<u8>) -> Result<PvsReader> {
        if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
            return Err(Error::format("not a citypvs .pvs file (bad magic bytes)"));
        }
        let mut h = Cursor::new(&bytes, "header");
        h.take(MAGIC.len(), "magic")?;
        let version = h.u32("version")?;
        if version == 1 || version == 2 {
            return Err(Error::format(format!(
                "version {version} file: rebake with this citypvs (it reads .pvs version {FORMAT_VERSION} only)"
            )));
        }
        if version != FORMAT_VERSION {
            return Err(Error::format(format!(
                ".pvs format version {version} is not supported (this citypvs reads version {FORMAT_VERSION})"
            )));
        }
        let flags = h.u32("flags")?;
        let file_bytes = h.u64("file length")?;
        if file_bytes != bytes.len() as u64 {
            return Err(Error::format(format!(
                "the file is {} bytes but its header says {file_bytes}: it is truncated or has extra bytes",
                bytes.len()
            )));
        }
        if bytes.len() < HEADER_BYTES + 32 {
            return Err(Error::format("file too short for a .pvs header"));
        }
        let body = bytes.len() - 32;
        if Sha256::digest(&bytes[..body]).as_slice() != &bytes[body..] {
            return Err(Error::format(
                "checksum mismatch: the file is corrupted (SHA-256 of its contents does not match its last 32 bytes)",
            ));
        }
        if flags != 0 {
            return Err(Error::format(format!(
                "unknown flags {flags:#x} in the header"
            )));
        }
        let parsed = parse(&bytes[..body])?;
        let corners = &parsed.corners;
        let vertices = &parsed.vertices;
        let grid = CellGrid::new(corners.len(), |c| corners[c].map(|v| vertices[v as usize]));
        Ok(PvsReader {
            bytes,
            parsed,
            grid,
        })
    }

    pub fn info(&self) -> &BakeInfo {
        &self.parsed.info
    }
    pub fn cell_count(&self) -> usize {
        self.parsed.corners.len()
    }
    pub fn object_ids(&self) -> &[String] {
        &self.parsed.object_ids
    }
    /// The object fingerprints, in object order (empty when the file has
    /// no fingerprint list).
    pub fn object_prints(&self) -> &[ObjectPrint] {
        &self.parsed.object_prints
    }
    /// Cells per block in this file.
    pub fn block_cells(&self) -> usize {
        self.parsed.block_cells
    }
    /// Number of distinct corner points of the cells.
    pub fn vertex_count(&self) -> usize {
        self.parsed.vertices.len()
    }
    /// The triangle of a cell in local metres. Panics if `cell >= cell_count()`.
    pub fn cell_triangle(&self, cell: usize) -> [DVec2; 3] {
        self.parsed.corners[cell].map(|v| self.parsed.vertices[v as usize])
    }
    /// All cell triangles in local metres (built on each call).
    pub fn cell_triangles(&self) -> Vec<[DVec2; 3]> {
        (0..self.cell_count())
            .map(|c| self.cell_triangle(c))
            .collect()
    }
    /// The cell containing the point (local metres), if any. A point on an
    /// edge shared by two cells goes to the lower-numbered one. A point in
    /// no cell but within [`super::mesh::SNAP_DISTANCE`] (2.8 mm) of one,
    /// which the grid of cell corners leaves along the free space's
    /// outline, goes to the nearest (each cell's set holds that far beyond
    /// it).
    pub fn cell_at(&self, p: DVec2) -> Option<usize> {
        self.grid
            .find(p, super::mesh::SNAP_DISTANCE, |c| self.cell_triangle(c))
    }
    /// Length of the whole file in bytes.
    pub fn file_bytes(&self) -> u64 {
        self.bytes.len() as u64
    }
    /// Bytes of the visible-set blocks.
    pub fn block_bytes(&self) -> u64 {
        (self.bytes.len() - 32 - self.parsed.blocks_at) as u64
    }
    fn block_offset(&self, b: usize) -> usize {
        let at = self.parsed.index_at + 8 * b;
        u64::from_le_bytes(self.bytes[at..at + 8].try_into().unwrap()) as usize
    }
    /// The coded bytes of block `b` (docs/FORMAT.md, "Blocks"); `b` must
    /// hold a cell.
    pub fn coded_block(&self, b: usize) -> &[u8] {
        &self.bytes[self.parsed.blocks_at + self.block_offset(b)
            ..self.parsed.blocks_at + self.block_offset(b + 1)]
    }
    fn check_cell(&self, cell: usize) -> Result<()> {
        if cell >= self.cell_count() {
            return Err(Error::format(format!(
                "cell {cell} does not exist (the file has {} cells)",
                self.cell_count()
            )));
        }
        Ok(())
    }
    fn to_input(&self, ranks: &[u32], marks: &mut Vec<u64>, out: &mut Vec<u32>) {
        ranks_to_input(ranks, &self.parsed.input_of_rank, marks, out);
    }
    /// The index in block `b` (which holds a cell) of its last cell.
    fn last_in_block(&self, b: usize) -> usize {
        let bc = self.parsed.block_cells;
        (self.cell_count() - b * bc).min(bc) - 1
    }
    /// Decode the cells of block `b` up to and including `last` (index in
    /// the block), calling `f(cell, ranks, references)` for each.
    fn decode_block(
        &self,
        b: usize,
        last: usize,
        f: impl FnMut(usize, &[u32], u8) -> Result<()>,
    ) -> Result<()> {
        let whole = (b * self.parsed.block_cells + last + 1 == self.cell_count())
            || last + 1 == self.parsed.block_cells;
        decode_block(
            self.coded_block(b),
            self.parsed.object_ids.len() as u32,
            self.parsed.block_cells,
            b,
            last,
            whole,
            f,
        )
    }
    /// Ascending input object indices visible from the cell; reads only the
    /// cell's block.
    pub fn visible(&self, cell: usize) -> Result<Vec<u32>> {
        self.check_cell(cell)?;
        let b = cell / self.parsed.block_cells;
        let (mut out, mut marks) = (Vec::new(), Vec::new());
        self.decode_block(b, cell % self.parsed.block_cells, |c, ranks, _| {
            if c == cell {
                self.to_input(ranks, &mut marks, &mut out);
            }
            Ok(())
        })?;
        Ok(out)
    }
    /// The sets (ascending input object indices) of the cells of block
    /// `b`, in order, each block decoded at once: memory one block's sets.
    pub fn block_sets(&self, b: usize) -> Result<Vec<Vec<u32>>> {
        if b * self.parsed.block_cells >= self.cell_count() {
            return Err(Error::format(format!("there is no block {b}")));
        }
        let last = self.last_in_block(b);
        let (mut out, mut marks) = (Vec::new(), Vec::new());
        let mut sets = Vec::with_capacity(last + 1);
        self.decode_block(b, last, |_, ranks, _| {
            self.to_input(ranks, &mut marks, &mut out);
            sets.push(out.clone());
            Ok(())
        })?;
        Ok(sets)
    }
    /// How many objects each cell of block `b` sees, in order (decoding
    /// the block, without mapping the sets to input indices).
    pub fn block_set_lens(&self, b: usize) -> Result<Vec<usize>> {
        if b * self.parsed.block_cells >= self.cell_count() {
            return Err(Error::format(format!("there is no block {b}")));
        }
        let mut lens = Vec::with_capacity(self.last_in_block(b) + 1);
        self.decode_block(b, self.last_in_block(b), |_, ranks, _| {
            lens.push(ranks.len());
            Ok(())
        })?;
        Ok(lens)
    }
    /// The input index of the object of each rank of the file's spatial
    /// numbering (docs/FORMAT.md, "Objects").
    pub fn input_of_rank(&self) -> &[u32] {
        &self.parsed.input_of_rank
    }
    /// Input ids of the objects visible from the cell.
    pub fn visible_ids(&self, cell: usize) -> Result<Vec<&str>> {
        Ok(self
            .visible(cell)?
            .into_iter()
            .map(|i| self.parsed.object_ids[i as usize].as_str())
            .collect())
    }
    /// The whole file decoded into memory (every cell's set at once: for
    /// tools and measurements on files known to be small, not for hostile
    /// ones, whose sets can expand far beyond the file's size).
    pub fn to_data(&self) -> Result<super::PvsData> {
        let mut visible = Vec::with_capacity(self.cell_count());
        self.for_each_visible(|_, s| {
            visible.push(s.to_vec());
            Ok(())
        })?;
        Ok(super::PvsData {
            info: self.info().clone(),
            object_ids: self.object_ids().to_vec(),
            object_prints: self.object_prints().to_vec(),
            cells: self.cell_triangles(),
            visible,
        })
    }
    /// Call `f(cell, visible)` for every cell in order, with the ascending
    /// input indices of its set, decoding each block once. Memory: one set.
    pub fn for_each_visible(&self, mut f: impl FnMut(usize, &[u32]) -> Result<()>) -> Result<()> {
        self.for_each_visible_mode(|c, v, _| f(c, v))
    }
    /// Like [`PvsReader::for_each_visible`], also giving how many earlier
    /// cells each cell's coding refers to (0 to 2, see docs/FORMAT.md).
    pub fn for_each_visible_mode(
        &self,
        mut f: impl FnMut(usize, &[u32], u8) -> Result<()>,
    ) -> Result<()> {
        let (mut out, mut marks) = (Vec::new(), Vec::new());
        let blocks = self.cell_count().div_ceil(self.parsed.block_cells);
        for b in 0..blocks {
            self.decode_block(b, self.last_in_block(b), |c, ranks, mode| {
                self.to_input(ranks, &mut marks, &mut out);
                f(c, &out, mode)
            })?;
        }
        Ok(())
    }
}

/// Everything the sections hold but the blocks themselves: the header, the
/// objects, the mesh and where the block index and blocks start.
struct Parsed {
    info: BakeInfo,
    object_ids: Vec<String>,
    /// The object fingerprint list (empty when the file has none).
    object_prints: Vec<ObjectPrint>,
    /// Input object index of each spatial rank.
    input_of_rank: Vec<u32>,
    vertices: Vec<DVec2>,
    corners: Vec<[u32; 3]>,
    block_cells: usize,
    /// Byte position of the block index and of the blocks in the file.
    index_at: usize,
    blocks_at: usize,
}

/// Parse everything before the checksum.
fn parse(body: &[u8]) -> Result<Parsed> {
    let mut h = Cursor::new(&body[..HEADER_BYTES], "header");
    h.take(24, "magic, version, flags and length")?;
    let mut params = [0.0; 7];
    for (v, name) in params.iter_mut().zip(BakeNumbers::NAMES) {
        *v = h.f64(name)?;
    }
    let kind = h.u32("frame kind")?;
    let has_crs = h.u32("CRS flag")?;
    let fx = h.f64("frame x")?;
    let fy = h.f64("frame y")?;
    let source_hash: [u8; 32] = h.take(32, "source hash")?.try_into().unwrap();
    let region_hash: [u8; 32] = h.take(32, "region hash")?.try_into().unwrap();
    let object_count = h.u32("object count")?;
    let cell_count = h.u32("cell count")?;
    let vertex_count = h.u32("vertex count")?;
    let block_cells = h.u32("cells per block")?;
    let mut lengths = [0u64; 6];
    for (len, name) in lengths.iter_mut().zip(SECTION_NAMES) {
        *len = h.u64(name)?;
    }
    h.done()?;
    if !matches!((kind, has_crs), (0, 0) | (1, 0 | 1)) {
        return Err(Error::format(format!(
            "unknown frame kind {kind} with CRS flag {has_crs}"
        )));
    }
    if !(1..=MAX_BLOCK_CELLS).contains(&block_cells) {
        return Err(Error::format(format!(
            "header says {block_cells} cells per block (1 to {MAX_BLOCK_CELLS} allowed)"
        )));
    }
    // The sections follow the header back to back and end at the checksum.
    let mut sections = [&body[0..0]; 6];
    let mut at = HEADER_BYTES as u64;
    for (k, len) in lengths.iter().enumerate() {
        let end = at.checked_add(*len).filter(|&e| e <= body.len() as u64);
        let Some(end) = end else {
            return Err(Error::format(format!(
                "the {} section of {len} bytes at byte {at} runs past the checksum (byte {})",
                SECTION_NAMES[k],
                body.len()
            )));
        };
        sections[k] = &body[at as usize..end as usize];
        at = end;
    }
    if at != body.len() as u64 {
        return Err(Error::format(format!(
            "the sections end at byte {at}, but the checksum starts at byte {}",
            body.len()
        )));
    }
    let index_at = HEADER_BYTES + (lengths[..4].iter().sum::<u64>() as usize);
    let blocks_at = index_at + lengths[4] as usize;

    // Strings.
    let mut s = Cursor::new(sections[0], "strings");
    let tool_version = s.string("tool version")?.to_string();
    let crs = if has_crs == 1 {
        Some(s.string("CRS name")?.to_string())
    } else {
        None
    };
    s.done()?;
    let frame = match kind {
        0 => Frame::LonLat { lon0: fx, lat0: fy },
        _ => Frame::Metric {
            origin: DVec2::new(fx, fy),
            crs,
        },
    };
    let info = BakeInfo {
        numbers: BakeNumbers::from_values(params),
        frame,
        source_hash,
        region_hash,
        tool_version,
    };
    info.validate()?;

    // Objects: each takes at least 2 bytes (id length and rank entry).
    let n = object_count as usize;
    let mut o = Cursor::new(sections[1], "objects");
    if n > o.left() / 2 {
        return Err(Error::format(format!(
            "header claims {n} objects, more than the objects section of {} bytes can hold",
            o.left()
        )));
    }
    let mut object_ids: Vec<String> = Vec::with_capacity(n);
    for k in 0..n {
        let entry_start = o.pos;
        let shared = o.varint(&format!("shared bytes of the id of object {k}"))?;
        let rest = o.string(&format!("id of object {k}"))?;
        let previous = object_ids.last().map_or("", String::as_str);
        let shared = usize::try_from(shared)
            .ok()
            .filter(|&s| s <= previous.len() && previous.is_char_boundary(s))
            .ok_or_else(|| {
                Error::format(format!(
                    "the id of object {k} shares {shared} bytes with the previous id of {} bytes",
                    previous.len()
                ))
            })?;
        let entry = o.pos - entry_start;
        if shared + rest.len() > super::ID_EXPANSION * entry {
            return Err(Error::format(format!(
                "the id of object {k} is {} bytes from an entry of {entry} (at most {} times as many allowed)",
                shared + rest.len(),
                super::ID_EXPANSION
            )));
        }
        let mut id = String::with_capacity(shared + rest.len());
        id.push_str(&previous[..shared]);
        id.push_str(rest);
        object_ids.push(id);
    }
    let mut input_of_rank = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    for r in 0..n {
        let i = o.varint("spatial numbering")?;
        if i >= n as u64 || seen[i as usize] {
            return Err(Error::format(format!(
                "the spatial numbering is not a permutation of the objects (rank {r} names object {i})"
            )));
        }
        seen[i as usize] = true;
        input_of_rank.push(i as u32);
    }
    let rest = o.take(o.left(), "object fingerprints")?;
    let object_prints = super::prints::read_prints(rest, n, &input_of_rank)?;

    // Vertices and triangles: range coded, each section at least
    // VERTEX_MIN_BYTES per vertex and CELL_MIN_BYTES per cell.
    use super::mesh::{CELL_MIN_BYTES, VERTEX_MIN_BYTES};
    if u64::from(vertex_count) > lengths[2] / VERTEX_MIN_BYTES {
        return Err(Error::format(format!(
            "header claims {vertex_count} vertices, more than the vertices section of {} bytes can hold",
            lengths[2]
        )));
    }
    let cells = cell_count as usize;
    if u64::from(cell_count) > lengths[3] / CELL_MIN_BYTES {
        return Err(Error::format(format!(
            "header claims {cells} cells, more than the triangles section of {} bytes can hold",
            lengths[3]
        )));
    }
    if u64::from(vertex_count) > 3 * u64::from(cell_count) {
        return Err(Error::format(format!(
            "header claims {vertex_count} vertices for {cells} cells (at most 3 per cell)"
        )));
    }
    let vertices =
        super::mesh::decode_vertices(sections[2], vertex_count).map_err(Error::format)?;
    let corners = super::mesh::decode_triangles(sections[3], cell_count, vertex_count)
        .map_err(Error::format)?;

    // Block index: ascending offsets from 0 to the blocks' length.
    let blocks = cells.div_ceil(block_cells as usize);
    if lengths[4] != 8 * (blocks as u64 + 1) {
        return Err(Error::format(format!(
            "the block index is {} bytes, but {blocks} blocks need {}",
            lengths[4],
            8 * (blocks + 1)
        )));
    }
    let mut b = Cursor::new(sections[4], "block index");
    let mut previous = 0u64;
    for k in 0..=blocks {
        let off = b.u64("block offset")?;
        if (k == 0 && off != 0) || off < previous || off > lengths[5] {
            return Err(Error::format(format!(
                "block offset {k} ({off}) is out of order or out of range"
            )));
        }
        previous = off;
    }
    if previous != lengths[5] {
        return Err(Error::format(format!(
            "block offsets end at {previous}, but the blocks take {} bytes",
            lengths[5]
        )));
    }
    Ok(Parsed {
        info,
        object_ids,
        object_prints,
        input_of_rank,
        vertices,
        corners,
        block_cells: block_cells as usize,
        index_at,
        blocks_at,
    })
}

/// Map ascending spatial ranks to ascending input indices in `out` (the
/// input index of rank r is `input_of_rank[r]`), through the bitset
/// `marks` (kept all zero between calls) when the set is large.
pub(crate) fn ranks_to_input(
    ranks: &[u32],
    input_of_rank: &[u32],
    marks: &mut Vec<u64>,
    out: &mut Vec<u32>,
) {
    out.clear();
    let words = input_of_rank.len().div_ceil(64);
    if marks.len() != words {
        marks.clear();
        marks.resize(words, 0);
    }
    if ranks.len() < words {
        out.extend(ranks.iter().map(|&r| input_of_rank[r as usize]));
        out.sort_unstable();
        return;
    }
    for &r in ranks {
        let i = input_of_rank[r as usize];
        marks[i as usize / 64] |= 1 << (i % 64);
    }
    for (k, word) in marks.iter_mut().enumerate() {
        let mut w = std::mem::take(word);
        while w != 0 {
            out.push((k * 64) as u32 + w.trailing_zeros());
            w &= w - 1;
        }
    }
}

/// Decode block `b` (its `bytes`; blocks of `block_cells` cells, sets of
/// ranks below `n`) up to and including its cell `last`, calling
/// `f(cell, ranks, references)` for each; with `whole`, the block must end
/// right after cell `last`. Errors name the cell or the block.
pub(crate) fn decode_block(
    bytes: &[u8],
    n: u32,
    block_cells: usize,
    b: usize,
    last: usize,
    whole: bool,
    mut f: impl FnMut(usize, &[u32], u8) -> Result<()>,
) -> Result<()> {
    let first = b * block_cells;
    let mut state = BlockDecoder::new(bytes, n, block_cells as u32)
        .map_err(|e| Error::format(format!("visible set of cell {first}: {e}")))?;
    let mut set = Vec::new();
    for k in 0..=last {
        let cell = first + k;
        let refs = state
            .next(&mut set)
            .map_err(|e| Error::format(format!("visible set of cell {cell}: {e}")))?;
        f(cell, &set, refs)?;
    }
    if whole && state.pos() != bytes.len() {
        return Err(Error::format(format!(
            "block {b} has {} bytes after its last cell",
            bytes.len() - state.pos()
        )));
    }
    Ok(())
}
