//! The `.pvs` file: its layout (docs/FORMAT.md), the compression of each
//! cell's visible set, atomic writing, and a reader that decodes one cell's
//! record without touching the others.
//!
//! OWNER: pvs helper. The types and functions below are the agreed interface.

use std::path::Path;

use glam::DVec2;

use crate::Result;
use crate::input::Frame;

/// The bake parameters and provenance stored in the header.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeInfo {
    pub eps: f64,
    pub eye_height: f64,
    pub pixel: f64,
    pub max_cell_edge: f64,
    pub margin: f64,
    /// Map from local metres back to the input frame.
    pub frame: Frame,
    /// SHA-256 of the input file.
    pub source_hash: [u8; 32],
    /// citypvs version that wrote the file.
    pub tool_version: String,
}

/// Everything a `.pvs` file holds, decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct PvsData {
    pub info: BakeInfo,
    /// Object ids (input building ids), index = object index.
    pub object_ids: Vec<String>,
    /// Cell triangles in local metres, counter-clockwise.
    pub cells: Vec<[DVec2; 3]>,
    /// Per cell, the ascending object indices of its visible set.
    pub visible: Vec<Vec<u32>>,
}

/// Sizes measured while writing.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WriteStats {
    pub file_bytes: u64,
    /// Bytes of all visible-set records as written.
    pub record_bytes: u64,
    /// What the same sets would take as raw bitsets.
    pub raw_bitset_bytes: u64,
    /// What the same sets would take as Quake-style run-length coded bitsets.
    pub rle_bitset_bytes: u64,
}

/// Write the file atomically (temporary file in the same folder, then rename).
pub fn write_pvs(_path: &Path, _data: &PvsData) -> Result<WriteStats> {
    todo!("pvs helper")
}

/// Reads a `.pvs` file; each cell's record is decoded on demand.
pub struct PvsReader {
    _private: (),
}

impl PvsReader {
    /// Open and validate the header and tables.
    pub fn open(_path: &Path) -> Result<PvsReader> {
        todo!("pvs helper")
    }
    pub fn info(&self) -> &BakeInfo {
        todo!()
    }
    pub fn cell_count(&self) -> usize {
        todo!()
    }
    pub fn object_ids(&self) -> &[String] {
        todo!()
    }
    pub fn cell_triangle(&self, _cell: usize) -> [DVec2; 3] {
        todo!()
    }
    /// The cell containing the point (local metres), if any.
    pub fn cell_at(&self, _p: DVec2) -> Option<usize> {
        todo!()
    }
    /// Ascending object indices visible from the cell.
    pub fn visible(&self, _cell: usize) -> Result<Vec<u32>> {
        todo!()
    }
    /// Input ids of the objects visible from the cell.
    pub fn visible_ids(&self, cell: usize) -> Result<Vec<&str>> {
        Ok(self
            .visible(cell)?
            .into_iter()
            .map(|i| self.object_ids()[i as usize].as_str())
            .collect())
    }
}
