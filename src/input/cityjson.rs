//! CityJSON 1.1 / 2.0 files: Building and BuildingPart objects.

use serde_json::Value;

use super::InputOptions;
use super::assemble::Parsed;
use crate::{Error, Result};

/// Parse a CityJSON document into buildings.
pub fn parse(_root: &Value, name: &str, _options: &InputOptions) -> Result<Parsed> {
    Err(Error::new(format!(
        "{name}: CityJSON reading is not implemented yet"
    )))
}
