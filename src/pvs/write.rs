//! Writing version 3 files (docs/FORMAT.md): [`PvsWriter`] takes the header,
//! the objects and the cell triangles up front, then the finished cells'
//! visible sets one at a time in cell order; it holds only the output so far
//! and the block being filled. [`encode_pvs`] and [`write_pvs`] write a whole
//! [`PvsData`] through it.

use std::path::Path;

use glam::DVec2;

use super::prints::ObjectPrint;
use sha2::{Digest, Sha256};

use super::blocks::BlockEncoder;
use super::codec::{bitset_len, write_leb128, zero_rle_len};
use super::read::ranks_to_input;
use super::{BLOCK_CELLS, BakeInfo, FORMAT_VERSION, HEADER_BYTES, MAGIC, PvsData, WriteStats};
use crate::frame::Frame;
use crate::{Error, Result};

/// A streaming `.pvs` writer. Cells' sets are pushed in cell order; the
/// file is complete after [`PvsWriter::finish`].
pub struct PvsWriter {
    out: Vec<u8>,
    object_count: u32,
    cell_count: usize,
    block_cells: usize,
    /// Spatial rank of each input object index, and the input index of
    /// each rank.
    rank_of: Vec<u32>,
    input_of_rank: Vec<u32>,
    /// Where the block index starts in `out`, and where the blocks start.
    index_at: usize,
    blocks_at: usize,
    pushed: usize,
    block: BlockEncoder,
    cur: Vec<u32>,
    stats: WriteStats,
    coding_counts: [u64; 3],
}

pub(super) fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}
pub(super) fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}
pub(super) fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_le_bytes());
}
/// The header's start, the same in both layouts: magic, `version`, flags
/// 0, the file length 0 (patched when the file is done), then `numbers`
/// (eps, eye height, pixel, max cell edge, margin, ... as the layout has
/// them), frame kind (0 lon/lat, 1 metric), CRS flag and the frame's
/// origin. Returns the frame's CRS name, which goes into the strings.
pub(super) fn put_header_start<'f>(
    out: &mut Vec<u8>,
    version: u32,
    numbers: &[f64],
    frame: &'f Frame,
) -> Option<&'f str> {
    out.extend_from_slice(&MAGIC);
    put_u32(out, version);
    put_u32(out, 0); // flags
    put_u64(out, 0); // file length
    for &v in numbers {
        put_f64(out, v);
    }
    let (kind, crs, x, y) = match frame {
        Frame::LonLat { lon0, lat0 } => (0, None, *lon0, *lat0),
        Frame::Metric { origin, crs } => (1, crs.as_deref(), origin.x, origin.y),
    };
    put_u32(out, kind);
    put_u32(out, u32::from(crs.is_some()));
    put_f64(out, x);
    put_f64(out, y);
    crs
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    write_leb128(out, s.len() as u64);
    out.extend_from_slice(s.as_bytes());
}
fn patch_u64(out: &mut [u8], at: usize, v: u64) {
    out[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

/// Position along a Hilbert curve over a 65536 x 65536 grid.
fn hilbert(mut x: u32, mut y: u32) -> u64 {
    let mut d = 0u64;
    let mut s = 1u32 << 15;
    while s > 0 {
        let rx = u32::from(x & s != 0);
        let ry = u32::from(y & s != 0);
        d += u64::from(s) * u64::from(s) * u64::from((3 * rx) ^ ry);
        if ry == 0 {
            if rx == 1 {
                x = 0xffff - x;
                y = 0xffff - y;
            }
            std::mem::swap(&mut x, &mut y);
        }
        s >>= 1;
    }
    d
}

/// The spatial numbering: objects sorted by the Hilbert curve position of
/// their point on a 65536 x 65536 grid over the square around the points'
/// bounding box, ties by input index. Returns the input index of each
/// rank.
pub fn spatial_ranks(points: &[DVec2]) -> Vec<u32> {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in points {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let side = (hi - lo).max_element().max(1e-9);
    let q = |v: f64, lo: f64| (((v - lo) / side * 65535.0).round() as u32).min(65535);
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| (hilbert(q(p.x, lo.x), q(p.y, lo.y)), i as u32))
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// The spatial numbering of the objects (the input index of each rank):
/// by the centres of their fingerprints' rectangles when there are
/// fingerprints, else by `points` (one per object).
pub fn object_ranks(prints: &[ObjectPrint], points: Vec<DVec2>) -> Vec<u32> {
    spatial_ranks(&numbering_points(prints, points))
}

/// The spatial rank of each input object index, from the input index of
/// each rank (as [`object_ranks`] gives it).
pub(crate) fn rank_of_input(input_of_rank: &[u32]) -> Vec<u32> {
    let mut rank_of = vec![0u32; input_of_rank.len()];
    for (r, &i) in input_of_rank.iter().enumerate() {
        rank_of[i as usize] = r as u32;
    }
    rank_of
}

/// A set of input object indices as the block coder takes it: their ranks
/// (`rank_of[i]`), ascending, in `out`.
pub(crate) fn set_ranks(set: &[u32], rank_of: &[u32], out: &mut Vec<u32>) {
    out.clear();
    out.extend(set.iter().map(|&i| rank_of[i as usize]));
    out.sort_unstable();
}

/// The point the numbering uses for each object: the centre of its stored
/// rectangle when the file has the fingerprint list, else `points`.
fn numbering_points(prints: &[ObjectPrint], points: Vec<DVec2>) -> Vec<DVec2> {
    if prints.is_empty() {
        return points;
    }
    prints
        .iter()
        .map(|p| {
            let r = super::prints::stored_rect(&p.rect);
            DVec2::new((r[0] + r[2]) / 2.0, (r[1] + r[3]) / 2.0)
        })
        .collect()
}

/// Append the ids, each as the bytes it shares with the previous id and
/// the rest (docs/FORMAT.md, "Objects"): an id is never more than
/// [`super::ID_EXPANSION`] times as long as its entry.
fn put_ids(out: &mut Vec<u8>, ids: &[String]) {
    let mut previous: &str = "";
    for id in ids {
        let common = id
            .bytes()
            .zip(previous.bytes())
            .take_while(|(a, b)| a == b)
            .count();
        // Keep at least 1/16 of the id in the entry itself.
        let keep = id.len().div_ceil(super::ID_EXPANSION);
        let mut shared = common.min(id.len().saturating_sub(keep));
        while !id.is_char_boundary(shared) {
            shared -= 1;
        }
        write_leb128(out, shared as u64);
        put_str(out, &id[shared..]);
        previous = id;
    }
}

impl PvsWriter {
    /// Start a file with cells of [`BLOCK_CELLS`] per block.
    pub fn new(
        info: BakeInfo,
        object_ids: Vec<String>,
        object_points: Vec<DVec2>,
        cells: Vec<[DVec2; 3]>,
    ) -> Result<PvsWriter> {
        PvsWriter::with_block_cells(info, object_ids, object_points, cells, BLOCK_CELLS)
    }

    /// [`PvsWriter::new`] with the object fingerprint list (one per object,
    /// or empty for none).
    pub fn with_prints(
        info: BakeInfo,
        object_ids: Vec<String>,
        object_prints: Vec<ObjectPrint>,
        object_points: Vec<DVec2>,
        cells: Vec<[DVec2; 3]>,
    ) -> Result<PvsWriter> {
        PvsWriter::start(
            info,
            object_ids,
            object_prints,
            object_points,
            cells,
            BLOCK_CELLS,
        )
    }

    /// Start a file with `block_cells` cells per block (1 to
    /// [`super::MAX_BLOCK_CELLS`]); for measuring the block size.
    pub fn with_block_cells(
        info: BakeInfo,
        object_ids: Vec<String>,
        object_points: Vec<DVec2>,
        cells: Vec<[DVec2; 3]>,
        block_cells: u32,
    ) -> Result<PvsWriter> {
        PvsWriter::start(
            info,
            object_ids,
            Vec::new(),
            object_points,
            cells,
            block_cells,
        )
    }

    fn start(
        info: BakeInfo,
        object_ids: Vec<String>,
        object_prints: Vec<ObjectPrint>,
        object_points: Vec<DVec2>,
        cells: Vec<[DVec2; 3]>,
        block_cells: u32,
    ) -> Result<PvsWriter> {
        info.validate()?;
        if !(1..=super::MAX_BLOCK_CELLS).contains(&block_cells) {
            return Err(Error::format(format!("{block_cells} cells per block")));
        }
        let n = object_ids.len();
        if u32::try_from(n).is_err() || u32::try_from(cells.len()).is_err() {
            return Err(Error::format("more than 2^32 - 1 objects or cells"));
        }
        if !object_prints.is_empty() && object_prints.len() != n {
            return Err(Error::format(format!(
                "{n} objects but {} object fingerprints",
                object_prints.len()
            )));
        }
        // Without fingerprints the caller's points number the objects.
        if object_prints.is_empty() && object_points.len() != n {
            return Err(Error::format(format!(
                "{n} objects but {} object points",
                object_points.len()
            )));
        }
        if let Some(k) = object_prints
            .iter()
            .position(|p| !super::prints::rect_storable(&p.rect))
        {
            return Err(Error::format(format!(
                "object {k}'s rectangle {:?} cannot be stored (not finite, inverted, or beyond 2^52 grid steps)",
                object_prints[k].rect
            )));
        }
        if let Some(k) = object_points.iter().position(|p| !p.is_finite()) {
            return Err(Error::format(format!("object {k} has a non-finite point")));
        }
        for (c, tri) in cells.iter().enumerate() {
            if !tri.iter().all(|p| p.is_finite()) {
                return Err(Error::format(format!(
                    "cell {c} has a non-finite coordinate"
                )));
            }
        }
        let input_of_rank = object_ranks(&object_prints, object_points);
        let rank_of = rank_of_input(&input_of_rank);

        // Vertices in order of first use, corners as back-references.
        let (vertices, corners) = super::mesh::index_mesh(&cells);
        let vertex_count = u32::try_from(vertices.len())
            .map_err(|_| Error::format("more than 2^32 - 1 vertices"))?;
        let mut numbers = Vec::with_capacity(vertices.len());
        for v in &vertices {
            numbers.push(super::mesh::grid_numbers(*v).ok_or_else(|| {
                Error::format(format!(
                    "cell corner ({}, {}) is not on the 1/256 m grid of cell corners",
                    v.x, v.y
                ))
            })?);
        }
        let vertex_bytes = super::mesh::encode_vertices(&numbers);
        let triangles = super::mesh::encode_triangles(&corners);

        let mut strings = Vec::new();
        put_str(&mut strings, &info.tool_version);
        if let Frame::Metric { crs: Some(crs), .. } = &info.frame {
            put_str(&mut strings, crs);
        }
        let mut objects = Vec::new();
        put_ids(&mut objects, &object_ids);
        for &i in &input_of_rank {
            write_leb128(&mut objects, u64::from(i));
        }
        super::prints::write_prints(&mut objects, &object_prints, &input_of_rank);
        let block_count = cells.len().div_ceil(block_cells as usize);
        let index_len = 8 * (block_count + 1);

        let mut out = Vec::new();
        put_header_start(
            &mut out,
            FORMAT_VERSION,
            &info.numbers.values(),
            &info.frame,
        );
        out.extend_from_slice(&info.source_hash);
        out.extend_from_slice(&info.region_hash);
        put_u32(&mut out, n as u32);
        put_u32(&mut out, cells.len() as u32);
        put_u32(&mut out, vertex_count);
        put_u32(&mut out, block_cells);
        for len in [
            strings.len(),
            objects.len(),
            vertex_bytes.len(),
            triangles.len(),
            index_len,
            0, // blocks, patched by finish
        ] {
            put_u64(&mut out, len as u64);
        }
        debug_assert_eq!(out.len(), HEADER_BYTES);
        out.extend_from_slice(&strings);
        out.extend_from_slice(&objects);
        out.extend_from_slice(&vertex_bytes);
        out.extend_from_slice(&triangles);
        let index_at = out.len();
        out.resize(index_at + index_len, 0);
        let blocks_at = out.len();
        let stats = WriteStats {
            object_bytes: objects.len() as u64,
            mesh_bytes: (vertex_bytes.len() + triangles.len()) as u64,
            ..WriteStats::default()
        };
        Ok(PvsWriter {
            out,
            object_count: n as u32,
            cell_count: cells.len(),
            block_cells: block_cells as usize,
            rank_of,
            input_of_rank,
            index_at,
            blocks_at,
            pushed: 0,
            block: BlockEncoder::new(n as u32, block_cells),
            cur: Vec::new(),
            stats,
            coding_counts: [0; 3],
        })
    }

    /// Add the next cell's visible set: strictly ascending input object indices.
    pub fn push_cell(&mut self, visible: &[u32]) -> Result<()> {
        let c = self.pushed;
        if c >= self.cell_count {
            return Err(Error::format(format!(
                "more visible sets than the {} cells",
                self.cell_count
            )));
        }
        if !visible.windows(2).all(|w| w[0] < w[1]) {
            return Err(Error::format(format!(
                "visible set of cell {c} is not strictly ascending"
            )));
        }
        if let Some(&last) = visible.last()
            && last >= self.object_count
        {
            return Err(Error::format(format!(
                "visible set of cell {c} holds object {last}, but there are only {} objects",
                self.object_count
            )));
        }
        set_ranks(visible, &self.rank_of, &mut self.cur);
        let refs = self.block.push(&self.cur);
        count_cell(
            &mut self.stats,
            &mut self.coding_counts,
            self.object_count,
            visible,
            refs,
        );
        self.pushed += 1;
        if self.pushed.is_multiple_of(self.block_cells) || self.pushed == self.cell_count {
            let bytes = self.block.finish();
            self.close_block(&bytes);
        }
        Ok(())
    }

    /// Add the next whole block, coded elsewhere in this file's numbering
    /// and block size (a shard's or a checkpoint's block): its `block_cells`
    /// cells, or the rest of the file's cells for the last block. No cell
    /// of the block may have been pushed. The bytes are decoded first, so a
    /// malformed block is refused and the statistics are those
    /// [`PvsWriter::push_cell`] gathers.
    pub fn push_block(&mut self, bytes: &[u8]) -> Result<()> {
        let first = self.pushed;
        if !first.is_multiple_of(self.block_cells) {
            return Err(Error::format(format!(
                "a whole block cannot start at cell {first}, inside a block"
            )));
        }
        let cells = self.block_cells.min(self.cell_count - first);
        if cells == 0 {
            return Err(Error::format(format!(
                "more visible sets than the {} cells",
                self.cell_count
            )));
        }
        let (mut marks, mut visible) = (Vec::new(), Vec::new());
        super::read::decode_block(
            bytes,
            self.object_count,
            self.block_cells,
            first / self.block_cells,
            cells - 1,
            true,
            |_, ranks, refs| {
                ranks_to_input(ranks, &self.input_of_rank, &mut marks, &mut visible);
                count_cell(
                    &mut self.stats,
                    &mut self.coding_counts,
                    self.object_count,
                    &visible,
                    refs,
                );
                Ok(())
            },
        )?;
        self.pushed += cells;
        self.close_block(bytes);
        Ok(())
    }

    /// Append a finished block's bytes and its end in the block index.
    fn close_block(&mut self, bytes: &[u8]) {
        self.out.extend_from_slice(bytes);
        let b = self.pushed.div_ceil(self.block_cells);
        let end = (self.out.len() - self.blocks_at) as u64;
        patch_u64(&mut self.out, self.index_at + 8 * b, end);
    }

    /// How many cells were coded with no, one and two references so far.
    pub fn coding_counts(&self) -> [u64; 3] {
        self.coding_counts
    }

    /// The complete file bytes (every cell must have been pushed).
    pub fn finish(mut self) -> Result<(Vec<u8>, WriteStats)> {
        if self.pushed != self.cell_count {
            return Err(Error::format(format!(
                "{} of {} cells' visible sets were written",
                self.pushed, self.cell_count
            )));
        }
        let blocks_len = (self.out.len() - self.blocks_at) as u64;
        patch_u64(&mut self.out, HEADER_BYTES - 8, blocks_len);
        let file_bytes = self.out.len() as u64 + 32;
        patch_u64(&mut self.out, 16, file_bytes);
        let digest = Sha256::digest(&self.out);
        self.out.extend_from_slice(&digest);
        self.stats.record_bytes = blocks_len;
        self.stats.file_bytes = file_bytes;
        self.stats.checksum = digest.into();
        Ok((self.out, self.stats))
    }

    /// Finish and write the file atomically (temporary file, then rename).
    pub fn finish_to(self, path: &Path) -> Result<WriteStats> {
        let (bytes, stats) = self.finish().map_err(|e| e.context(path.display()))?;
        crate::atomic::write_atomically(path, &bytes)?;
        Ok(stats)
    }
}

/// Count a coded cell's set (ascending input indices among `n` objects,
/// coded with `refs` references) in the statistics.
fn count_cell(
    stats: &mut WriteStats,
    coding_counts: &mut [u64; 3],
    n: u32,
    visible: &[u32],
    refs: u8,
) {
    let n = n as usize;
    stats.raw_bitset_bytes += bitset_len(n) as u64;
    stats.rle_bitset_bytes += zero_rle_len(visible, n);
    coding_counts[refs as usize] += 1;
}

/// A representative point per object when the caller has none: the mean
/// centroid of the cells that see it, near the object (objects seen by no
/// cell go to the origin). Neighbouring objects are seen from neighbouring
/// cells, so this numbers objects spatially enough for the coding.
pub fn points_from_sets(data: &PvsData) -> Vec<DVec2> {
    points_of_sets(data.object_ids.len(), &data.cells, &mut |f| {
        data.visible.iter().try_for_each(|s| f(s))
    })
    .expect("the sets of a PvsData are in memory")
}

/// The sets of the cells, in cell order, handed one at a time to the
/// callback (so a caller can stream them from a compact store).
pub type EachSet<'a> = dyn FnMut(&mut dyn FnMut(&[u32]) -> Result<()>) -> Result<()> + 'a;

/// [`points_from_sets`] over sets handed out one at a time (twice: the
/// mean centre and spread of the cells that see each object, then the mean
/// of those cells within that spread of the first mean, which stays near
/// the object rather than drifting along its long sight lines).
fn points_of_sets(objects: usize, cells: &[[DVec2; 3]], each: &mut EachSet) -> Result<Vec<DVec2>> {
    let centres: Vec<DVec2> = cells.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
    let mut sum = vec![DVec2::ZERO; objects];
    let mut square = vec![0.0f64; objects];
    let mut count = vec![0u32; objects];
    let mut pass = |sum: &mut [DVec2],
                    square: &mut [f64],
                    count: &mut [u32],
                    keep: &dyn Fn(usize, DVec2) -> bool|
     -> Result<()> {
        let mut cell = 0;
        each(&mut |set| {
            let Some(&centre) = centres.get(cell) else {
                return Err(Error::format(format!(
                    "more visible sets than the {} cells",
                    cells.len()
                )));
            };
            cell += 1;
            for &i in set {
                let i = i as usize;
                if i < objects && keep(i, centre) {
                    sum[i] += centre;
                    square[i] += centre.length_squared();
                    count[i] += 1;
                }
            }
            Ok(())
        })
    };
    pass(&mut sum, &mut square, &mut count, &|_, _| true)?;
    let mean: Vec<DVec2> = sum
        .iter()
        .zip(&count)
        .map(|(s, &k)| {
            if k > 0 {
                *s / f64::from(k)
            } else {
                DVec2::ZERO
            }
        })
        .collect();
    // Squared spread: mean squared distance of the cells from the mean.
    let spread: Vec<f64> = (0..objects)
        .map(|i| {
            if count[i] > 0 {
                (square[i] / f64::from(count[i]) - mean[i].length_squared()).max(0.0)
            } else {
                0.0
            }
        })
        .collect();
    let mut sum2 = vec![DVec2::ZERO; objects];
    let mut square2 = vec![0.0f64; objects];
    let mut count2 = vec![0u32; objects];
    pass(&mut sum2, &mut square2, &mut count2, &|i, c| {
        c.distance_squared(mean[i]) <= spread[i]
    })?;
    Ok((0..objects)
        .map(|i| {
            if count2[i] > 0 {
                sum2[i] / f64::from(count2[i])
            } else {
                mean[i]
            }
        })
        .collect())
}

/// Write a file whose sets are handed out three times by `each` (once to number
/// the objects, once to code them), never all held at once: the same bytes
/// as [`write_pvs`] of the same data.
pub fn write_streamed(
    path: &Path,
    info: BakeInfo,
    object_ids: Vec<String>,
    object_prints: Vec<ObjectPrint>,
    cells: Vec<[DVec2; 3]>,
    each: &mut EachSet,
) -> Result<WriteStats> {
    let run = || -> Result<(Vec<u8>, WriteStats)> {
        // With fingerprints the objects are numbered by their rectangles.
        let points = if object_prints.is_empty() {
            points_of_sets(object_ids.len(), &cells, each)?
        } else {
            Vec::new()
        };
        let count = cells.len();
        let mut w = PvsWriter::with_prints(info, object_ids, object_prints, points, cells)?;
        let mut pushed = 0;
        each(&mut |set| {
            pushed += 1;
            w.push_cell(set)
        })?;
        if pushed != count {
            return Err(Error::format(format!(
                "{count} cells but {pushed} visible sets"
            )));
        }
        w.finish()
    };
    let (bytes, stats) = run().map_err(|e| e.context(path.display()))?;
    crate::atomic::write_atomically(path, &bytes)?;
    Ok(stats)
}

/// The complete file bytes and the size measurements. Objects are numbered
/// spatially by [`points_from_sets`].
pub fn encode_pvs(data: &PvsData) -> Result<(Vec<u8>, WriteStats)> {
    encode_pvs_with_points(data, points_from_sets(data))
}

/// Like [`encode_pvs`] with one representative point per object given.
pub fn encode_pvs_with_points(data: &PvsData, points: Vec<DVec2>) -> Result<(Vec<u8>, WriteStats)> {
    if data.visible.len() != data.cells.len() {
        return Err(Error::format(format!(
            "{} cells but {} visible sets",
            data.cells.len(),
            data.visible.len()
        )));
    }
    let mut w = PvsWriter::with_prints(
        data.info.clone(),
        data.object_ids.clone(),
        data.object_prints.clone(),
        points,
        data.cells.clone(),
    )?;
    for set in &data.visible {
        w.push_cell(set)?;
    }
    w.finish()
}

/// Write the file atomically (temporary file in the same folder, then rename).
pub fn write_pvs(path: &Path, data: &PvsData) -> Result<WriteStats> {
    let (bytes, stats) = encode_pvs(data).map_err(|e| e.context(path.display()))?;
    crate::atomic::write_atomically(path, &bytes)?;
    Ok(stats)
}

/// Like [`write_pvs`] with one representative point per object given.
pub fn write_pvs_with_points(
    path: &Path,
    data: &PvsData,
    points: Vec<DVec2>,
) -> Result<WriteStats> {
    let (bytes, stats) =
        encode_pvs_with_points(data, points).map_err(|e| e.context(path.display()))?;
    crate::atomic::write_atomically(path, &bytes)?;
    Ok(stats)
}
