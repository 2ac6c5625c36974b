//! The `.pvs` file: its layout (docs/FORMAT.md, version 3), the coding of the
//! visible sets in small blocks of cells, a streaming writer, and a reader
//! that decodes any one cell's set by reading at most one block.
//!
//! Submodules: [`rc`] (the range coder), [`blocks`] (the sets' coding in
//! blocks), [`mesh`] (vertices and corners), [`codec`] (varints and the
//! version 1 record codings and the Quake/bitset measurements), [`write`] ([`PvsWriter`], [`encode_pvs`], [`write_pvs`]),
//! `read` ([`PvsReader`]: validating and decoding), `grid` (point lookup),
//! and `v1` (a reader of the old version 1 layout, kept only so measurements
//! can convert old files; [`PvsReader`] refuses version 1).

pub mod blocks;
pub mod codec;
mod grid;
pub mod mesh;
pub mod rc;
pub use grid::{CellGrid, distance_to_triangle, triangle_contains};
pub mod prints;
mod read;
#[doc(hidden)]
pub mod v1;
mod write;

use glam::DVec2;

use crate::frame::Frame;
use crate::{Error, Result};

pub use codec::SchemeSizes;
pub use read::PvsReader;
#[cfg(feature = "bake")]
pub(crate) use read::{decode_block, ranks_to_input};
pub use write::{
    EachSet, PvsWriter, encode_pvs, encode_pvs_with_points, object_ranks, points_from_sets,
    spatial_ranks, write_pvs, write_pvs_with_points, write_streamed,
};
#[cfg(feature = "bake")]
pub(crate) use write::{rank_of_input, set_ranks};

/// The bake parameters and provenance stored in the header.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeInfo {
    /// The bake's numbers as stored (checked by [`BakeInfo::validate`]).
    pub numbers: crate::BakeNumbers,
    /// Map from local metres back to the input frame.
    pub frame: Frame,
    /// SHA-256 of the input file.
    pub source_hash: [u8; 32],
    /// SHA-256 of the region polygon's canonical bytes; all zeros = no region.
    pub region_hash: [u8; 32],
    /// citypvs version that wrote the file.
    pub tool_version: String,
}

impl BakeInfo {
    /// The settings this header records, checked like any settings (a file
    /// is user data), with the region the caller gives for it (the header
    /// holds only the region's hash).
    pub fn settings(&self, region: Option<crate::model::Polygon>) -> Result<crate::Settings> {
        crate::Settings::new(crate::RawSettings::given(&self.numbers, region))
            .map_err(|e| Error::format(format!("the file's header is not a valid bake: {e}")))
    }

    /// Check every header number: finite, positive or non-negative as its
    /// meaning needs, and the pixel small enough for eps (pixel * sqrt(2) / 2
    /// <= eps), and the frame. The writer and the reader both call this.
    pub fn validate(&self) -> Result<()> {
        // The numbers go through the one settings check (docs/METHOD.md §4);
        // the frame is checked here.
        self.settings(None)?;
        let (x, y) = match &self.frame {
            Frame::LonLat { lon0, lat0 } => (*lon0, *lat0),
            Frame::Metric { origin, .. } => (origin.x, origin.y),
        };
        if !(x.is_finite() && y.is_finite()) {
            return Err(Error::format("header frame origin is not finite"));
        }
        if let Frame::LonLat { lon0, lat0 } = &self.frame
            && !(lon0.abs() <= 180.0 && lat0.abs() <= 90.0)
        {
            return Err(Error::format(format!(
                "header frame origin lon {lon0}, lat {lat0} is not a longitude/latitude"
            )));
        }
        Ok(())
    }
}

/// Everything a `.pvs` file holds, decoded.
#[derive(Clone, Debug, PartialEq)]
pub struct PvsData {
    pub info: BakeInfo,
    /// Object ids (input building ids), index = object index.
    pub object_ids: Vec<String>,
    /// Per object, its fingerprint (`prints.rs`); empty for none.
    pub object_prints: Vec<prints::ObjectPrint>,
    /// Cell triangles in local metres, counter-clockwise.
    pub cells: Vec<[DVec2; 3]>,
    /// Per cell, the ascending object indices of its visible set.
    pub visible: Vec<Vec<u32>>,
}

/// Sizes measured while writing.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WriteStats {
    pub file_bytes: u64,
    /// Bytes of the visible-set blocks (block section) as written.
    pub record_bytes: u64,
    /// What the same sets would take as raw bitsets.
    pub raw_bitset_bytes: u64,
    /// What the same sets would take as Quake-style run-length coded bitsets.
    pub rle_bitset_bytes: u64,
    /// Bytes of the object table (ids and spatial numbering).
    pub object_bytes: u64,
    /// Bytes of the vertex table and the triangles' corner indices.
    pub mesh_bytes: u64,
    /// The file's checksum, its last 32 bytes (the SHA-256 of all before
    /// them): two files with the same checksum hold the same bytes.
    #[serde(skip)]
    pub checksum: [u8; 32],
}

/// The first eight bytes of every `.pvs` file.
pub const MAGIC: [u8; 8] = *b"CITYPVS\0";
/// The layout version this code writes and reads.
pub const FORMAT_VERSION: u32 = 3;
/// Length of the fixed-size header in bytes.
pub const HEADER_BYTES: usize = 232;
/// Cells per block as the writer makes them (the reader accepts 1 to
/// [`MAX_BLOCK_CELLS`]).
pub const BLOCK_CELLS: u32 = 512;
/// An object id is at most this many times as long as its entry in the
/// objects section (so a small file cannot claim huge ids).
pub const ID_EXPANSION: usize = 16;
/// The largest block a reader accepts.
pub const MAX_BLOCK_CELLS: u32 = 1024;
/// The sections after the header, in file order.
pub const SECTION_NAMES: [&str; 6] = [
    "strings",
    "objects",
    "vertices",
    "triangles",
    "block index",
    "blocks",
];
