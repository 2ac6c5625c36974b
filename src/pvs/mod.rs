//! The `.pvs` file: its layout (docs/FORMAT.md), the compression of each
//! cell's visible set, atomic writing, and a reader that decodes one cell's
//! record without touching the others.
//!
//! Submodules: [`codec`] (record codings and their measurement), [`write`]
//! (serialising), [`read`] (validating and decoding), [`grid`] (point lookup).

pub mod codec;
mod grid;
mod read;
mod write;

use glam::DVec2;

use crate::input::Frame;

pub use codec::SchemeSizes;
pub use read::PvsReader;
pub use write::{encode_pvs, write_pvs};

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

/// The first eight bytes of every `.pvs` file.
pub const MAGIC: [u8; 8] = *b"CITYPVS\0";
/// The layout version this code writes and reads.
pub const FORMAT_VERSION: u32 = 1;
/// Length of the fixed-size header in bytes.
pub const HEADER_BYTES: usize = 168;
