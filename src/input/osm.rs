//! OpenStreetMap PBF extracts: building ways and multipolygon relations.

use super::InputOptions;
use super::assemble::Parsed;
use crate::{Error, Result};

/// Parse an OSM PBF file into buildings.
pub fn parse(_bytes: &[u8], name: &str, _options: &InputOptions) -> Result<Parsed> {
    Err(Error::new(format!(
        "{name}: OSM PBF reading is not implemented yet"
    )))
}
