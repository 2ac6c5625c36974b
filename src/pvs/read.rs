//! Reading and validating a version 1 `.pvs` file. The header, object table,
//! cells and record offsets are parsed at open; each visible-set record is
//! decoded only when asked for.

use std::path::Path;

use glam::DVec2;
use sha2::{Digest, Sha256};

use super::codec::{SchemeSizes, decode_record, measure};
use super::grid::CellGrid;
use super::{BakeInfo, FORMAT_VERSION, HEADER_BYTES, MAGIC};
use crate::input::Frame;
use crate::{Error, Result};

/// Reads a `.pvs` file; each cell's record is decoded on demand.
pub struct PvsReader {
    bytes: Vec<u8>,
    info: BakeInfo,
    object_ids: Vec<String>,
    cells: Vec<[DVec2; 3]>,
    /// Byte range of each record in `bytes`: record c is `ranges[c]..ranges[c + 1]`.
    ranges: Vec<usize>,
    grid: CellGrid,
}

/// Sequential little-endian reader over the file bytes.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(Error::new(format!(
                "{what} at byte {} runs past the end of the file",
                self.pos
            )));
        };
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn string(&mut self, what: &str) -> Result<String> {
        let len = self.u32(what)? as usize;
        let raw = self.take(len, what)?;
        String::from_utf8(raw.to_vec())
            .map_err(|_| Error::new(format!("{what} is not valid UTF-8")))
    }
    /// Check that the writer's recorded offset matches where we are.
    fn expect_at(&self, offset: u64, what: &str) -> Result<()> {
        if offset != self.pos as u64 {
            return Err(Error::new(format!(
                "header says the {what} start at byte {offset}, but they start at byte {}",
                self.pos
            )));
        }
        Ok(())
    }
    fn skip_padding(&mut self) -> Result<()> {
        while !self.pos.is_multiple_of(8) {
            if self.take(1, "padding")?[0] != 0 {
                return Err(Error::new(format!(
                    "padding byte {} is not zero",
                    self.pos - 1
                )));
            }
        }
        Ok(())
    }
}

impl PvsReader {
    /// Open and validate the header and tables.
    pub fn open(path: &Path) -> Result<PvsReader> {
        let bytes = std::fs::read(path)
            .map_err(|e| Error::new(format!("{}: cannot read: {e}", path.display())))?;
        PvsReader::from_bytes(bytes).map_err(|e| e.context(path.display()))
    }

    /// Validate and index a whole file held in memory.
    pub fn from_bytes(bytes: Vec<u8>) -> Result<PvsReader> {
        if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
            return Err(Error::new("not a citypvs .pvs file (bad magic bytes)"));
        }
        let mut c = Cursor {
            bytes: &bytes,
            pos: MAGIC.len(),
        };
        let version = c.u32("version")?;
        if version != FORMAT_VERSION {
            return Err(Error::new(format!(
                ".pvs format version {version} is not supported (this citypvs reads version {FORMAT_VERSION})"
            )));
        }
        let flags = c.u32("flags")?;
        let file_bytes = c.u64("file length")?;
        if file_bytes != bytes.len() as u64 {
            return Err(Error::new(format!(
                "the file is {} bytes but its header says {file_bytes}: it is truncated or has extra bytes",
                bytes.len()
            )));
        }
        if bytes.len() < HEADER_BYTES + 32 {
            return Err(Error::new("file too short for a .pvs header"));
        }
        let body = bytes.len() - 32;
        if Sha256::digest(&bytes[..body]).as_slice() != &bytes[body..] {
            return Err(Error::new(
                "checksum mismatch: the file is corrupted (SHA-256 of its contents does not match its last 32 bytes)",
            ));
        }
        if flags != 0 {
            return Err(Error::new(format!(
                "unknown flags {flags:#x} in the header"
            )));
        }
        let (info, object_ids, cells, ranges) = parse_body(&mut c, body)?;
        let grid = CellGrid::new(&cells);
        Ok(PvsReader {
            bytes,
            info,
            object_ids,
            cells,
            ranges,
            grid,
        })
    }

    pub fn info(&self) -> &BakeInfo {
        &self.info
    }
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }
    pub fn object_ids(&self) -> &[String] {
        &self.object_ids
    }
    /// The triangle of a cell in local metres. Panics if `cell >= cell_count()`.
    pub fn cell_triangle(&self, cell: usize) -> [DVec2; 3] {
        self.cells[cell]
    }
    /// All cell triangles in local metres.
    pub fn cell_triangles(&self) -> &[[DVec2; 3]] {
        &self.cells
    }
    /// The cell containing the point (local metres), if any. A point on an
    /// edge shared by two cells goes to the lower-numbered one.
    pub fn cell_at(&self, p: DVec2) -> Option<usize> {
        self.grid.find(&self.cells, p)
    }
    /// Length of the whole file in bytes.
    pub fn file_bytes(&self) -> u64 {
        self.bytes.len() as u64
    }
    /// The raw record of a cell (tag byte and payload).
    pub fn record(&self, cell: usize) -> Result<&[u8]> {
        if cell >= self.cells.len() {
            return Err(Error::new(format!(
                "cell {cell} does not exist (the file has {} cells)",
                self.cells.len()
            )));
        }
        Ok(&self.bytes[self.ranges[cell]..self.ranges[cell + 1]])
    }
    /// Ascending object indices visible from the cell.
    pub fn visible(&self, cell: usize) -> Result<Vec<u32>> {
        decode_record(self.record(cell)?, self.object_ids.len())
            .map_err(|e| Error::new(format!("visible set of cell {cell}: {e}")))
    }
    /// Input ids of the objects visible from the cell.
    pub fn visible_ids(&self, cell: usize) -> Result<Vec<&str>> {
        Ok(self
            .visible(cell)?
            .into_iter()
            .map(|i| self.object_ids()[i as usize].as_str())
            .collect())
    }
    /// Decode every record and measure it under each candidate coding.
    pub fn measure(&self) -> Result<SchemeSizes> {
        let sets = (0..self.cell_count())
            .map(|c| self.visible(c))
            .collect::<Result<Vec<_>>>()?;
        Ok(measure(
            sets.iter().map(|s| s.as_slice()),
            self.object_ids.len(),
        ))
    }
}

type Body = (BakeInfo, Vec<String>, Vec<[DVec2; 3]>, Vec<usize>);

fn parse_body(c: &mut Cursor, body: usize) -> Result<Body> {
    let mut params = [0.0; 5];
    for (v, name) in
        params
            .iter_mut()
            .zip(["eps", "eye_height", "pixel", "max_cell_edge", "margin"])
    {
        *v = c.f64(name)?;
    }
    let kind = c.u32("frame kind")?;
    let has_crs = c.u32("CRS flag")?;
    let fx = c.f64("frame x")?;
    let fy = c.f64("frame y")?;
    let source_hash: [u8; 32] = c.take(32, "source hash")?.try_into().unwrap();
    let object_count = c.u32("object count")? as usize;
    let cell_count = c.u32("cell count")? as usize;
    let objects_offset = c.u64("objects offset")?;
    let cells_offset = c.u64("cells offset")?;
    let index_offset = c.u64("record index offset")?;
    let records_offset = c.u64("records offset")?;
    let records_bytes = c.u64("records length")?;
    debug_assert_eq!(c.pos, HEADER_BYTES);
    let tool_version = c.string("tool version")?;
    let frame = match (kind, has_crs) {
        (0, 0) => Frame::LonLat { lon0: fx, lat0: fy },
        (1, 0 | 1) => Frame::Metric {
            origin: DVec2::new(fx, fy),
            crs: if has_crs == 1 {
                Some(c.string("CRS name")?)
            } else {
                None
            },
        },
        _ => {
            return Err(Error::new(format!(
                "unknown frame kind {kind} with CRS flag {has_crs}"
            )));
        }
    };
    if !(fx.is_finite() && fy.is_finite()) {
        return Err(Error::new("frame origin is not finite"));
    }
    c.expect_at(objects_offset, "object ids")?;
    // Each id needs at least its 4-byte length: bound the count before allocating.
    if object_count > (body - c.pos) / 4 {
        return Err(Error::new(format!(
            "header claims {object_count} objects, more than the file can hold"
        )));
    }
    let mut object_ids = Vec::with_capacity(object_count);
    for k in 0..object_count {
        object_ids.push(c.string(&format!("id of object {k}"))?);
    }
    c.skip_padding()?;
    c.expect_at(cells_offset, "cells")?;
    if cell_count > (body - c.pos) / 56 {
        return Err(Error::new(format!(
            "header claims {cell_count} cells, more than the file can hold"
        )));
    }
    let mut cells = Vec::with_capacity(cell_count);
    for k in 0..cell_count {
        let mut tri = [DVec2::ZERO; 3];
        for p in &mut tri {
            let what = format!("triangle of cell {k}");
            *p = DVec2::new(c.f64(&what)?, c.f64(&what)?);
            if !p.is_finite() {
                return Err(Error::new(format!("cell {k} has a non-finite coordinate")));
            }
        }
        cells.push(tri);
    }
    c.expect_at(index_offset, "record offsets")?;
    let index_end = index_offset + 8 * (cell_count as u64 + 1);
    if records_offset != index_end {
        return Err(Error::new(format!(
            "header says the records start at byte {records_offset}, expected {index_end}"
        )));
    }
    if records_offset.checked_add(records_bytes) != Some(body as u64) {
        return Err(Error::new(format!(
            "records of {records_bytes} bytes from byte {records_offset} do not end where the checksum starts (byte {body})"
        )));
    }
    let mut ranges = Vec::with_capacity(cell_count + 1);
    let mut previous = 0u64;
    for k in 0..=cell_count {
        let at = c.u64("record offset")?;
        if (k == 0 && at != 0) || at < previous || at > records_bytes {
            return Err(Error::new(format!(
                "record offset {k} ({at}) is out of order or out of range"
            )));
        }
        previous = at;
        ranges.push((records_offset + at) as usize);
    }
    if previous != records_bytes {
        return Err(Error::new(format!(
            "record offsets end at {previous}, but the records take {records_bytes} bytes"
        )));
    }
    let info = BakeInfo {
        eps: params[0],
        eye_height: params[1],
        pixel: params[2],
        max_cell_edge: params[3],
        margin: params[4],
        frame,
        source_hash,
        tool_version,
    };
    Ok((info, object_ids, cells, ranges))
}
