//! Reading city footprint files: format detection, parsing, heights,
//! projection to local metres, and repair of bad rings. Owns everything
//! between a path on disk and a [`City`] of valid buildings.
//!
//! OWNER: input helper. The types below are the agreed interface; the
//! implementation lives in submodules of this folder.

pub mod projection;

use std::path::Path;

use crate::Result;
use crate::model::Building;
pub use projection::Frame;

/// Default height in metres for a building with no height or level tags.
pub const DEFAULT_HEIGHT: f64 = 9.0;
/// Metres per storey when the height comes from a level count.
pub const METRES_PER_LEVEL: f64 = 3.0;

/// The input file formats citypvs reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Geojson,
    OsmPbf,
    Cityjson,
}

/// How to read an input file.
#[derive(Clone, Debug)]
pub struct InputOptions {
    /// Read coordinates as metres as they are (no projection).
    pub metric: bool,
    /// Height for buildings with no height information.
    pub default_height: f64,
    /// Turn every warning into an error.
    pub strict: bool,
    /// Force a format instead of detecting it.
    pub format: Option<Format>,
}

impl Default for InputOptions {
    fn default() -> Self {
        InputOptions {
            metric: false,
            default_height: DEFAULT_HEIGHT,
            strict: false,
            format: None,
        }
    }
}

/// Something that was repaired or skipped, naming the feature.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Warning {
    /// The feature's id, or `#<index>` when it has none.
    pub feature: String,
    /// What was wrong and what was done.
    pub message: String,
}

/// What reading did to the input.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct InputReport {
    /// Features looked at that could be buildings.
    pub features_read: usize,
    /// Buildings kept after repair.
    pub buildings: usize,
    /// Features repaired (and kept).
    pub repaired: Vec<Warning>,
    /// Features skipped.
    pub skipped: Vec<Warning>,
}

/// A city read from a file: buildings in local metres plus how to map back.
#[derive(Clone, Debug)]
pub struct City {
    /// Buildings in input order, ids unique.
    pub buildings: Vec<Building>,
    /// The map from local metres back to the input's coordinates.
    pub frame: Frame,
    /// SHA-256 of the input file's bytes.
    pub source_hash: [u8; 32],
    /// What was repaired or skipped.
    pub report: InputReport,
}

/// Read a city file. Errors name the file, the feature and what is wrong.
pub fn read_city(path: &Path, options: &InputOptions) -> Result<City> {
    let bytes = std::fs::read(path)
        .map_err(|e| crate::Error::new(format!("{}: cannot read: {e}", path.display())))?;
    read_city_bytes(&bytes, &path.display().to_string(), options)
}

/// Read a city from bytes; `name` is used in messages (usually the path).
pub fn read_city_bytes(_bytes: &[u8], name: &str, _options: &InputOptions) -> Result<City> {
    Err(crate::Error::new(format!(
        "{name}: reading is not implemented yet"
    )))
}

/// Read a region of interest: a GeoJSON Polygon (or a Feature or
/// FeatureCollection holding one) in the city's input frame, into local metres.
pub fn read_region(path: &Path, _frame: &Frame) -> Result<crate::model::Polygon> {
    Err(crate::Error::new(format!(
        "{}: --region is not implemented yet",
        path.display()
    )))
}
