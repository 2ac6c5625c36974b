//! Reading city footprint files: format detection, parsing, heights,
//! projection to local metres, and repair of bad rings. Owns everything
//! between a path on disk and a [`City`] of valid buildings.
//!
//! The types below are the agreed interface; the work is done by the
//! submodules: [`detect`] (which format), [`geojson`], [`osm`], [`cityjson`]
//! (parsing), [`height`] (height tags), [`assemble`] (ids, frame, projection,
//! report), [`repair`] (valid footprints) and [`projection`].

pub mod assemble;
pub mod cityjson;
pub mod detect;
pub mod geojson;
pub mod height;
pub mod opensided;
pub mod osm;
pub use crate::frame as projection;
pub mod repair;

use std::path::Path;

use crate::Result;
use crate::model::{self, Building};
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
    /// The default height was asked for (a format without height tags
    /// refuses it rather than ignoring it).
    pub default_height_given: bool,
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
            default_height_given: false,
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
    let starts_right = |b: &[u8]| detect::sniff(b) != detect::Content::Unknown;
    let bytes =
        crate::infile::read_whole(path, starts_right, "a GeoJSON, CityJSON or OSM PBF file")?;
    read_city_bytes(&bytes, &path.display().to_string(), options)
}

/// Read a city from bytes; `name` is used in messages (usually the path).
pub fn read_city_bytes(bytes: &[u8], name: &str, options: &InputOptions) -> Result<City> {
    if let Err(why) = height::check_height(options.default_height) {
        return Err(crate::Error::input(format!(
            "{name}: --default-height: {why}"
        )));
    }
    if bytes.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(crate::Error::input(format!("{name}: the file is empty")));
    }
    let parsed = match detect::format(bytes, name, options.format)? {
        Format::OsmPbf => osm::parse(bytes, name, options)?,
        Format::Cityjson => cityjson::parse(&detect::decode_json(bytes, name)?, name, options)?,
        Format::Geojson => geojson::parse(&geojson::decode(bytes, name)?, name, options)?,
    };
    assemble::assemble(parsed, name, bytes, options)
}

/// Read a region of interest: a GeoJSON Polygon (or a Feature or
/// FeatureCollection holding one) in the city's input frame, into local metres.
pub fn read_region(path: &Path, frame: &Frame) -> Result<crate::model::Polygon> {
    let name = path.display().to_string();
    let starts_right = |b: &[u8]| detect::sniff(b) == detect::Content::Json;
    let bytes = crate::infile::read_whole(path, starts_right, "a GeoJSON file")?;
    let rings = geojson::parse_region(&geojson::decode(&bytes, &name)?, &name)?;
    if rings
        .iter()
        .flatten()
        .any(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(crate::Error::input(format!(
            "{name}: region: a coordinate is not finite"
        )));
    }
    if let Frame::LonLat { .. } = frame
        && let Some(p) = rings
            .iter()
            .flatten()
            .find(|p| p[0].abs() > 180.0 || p[1].abs() > 90.0)
    {
        return Err(crate::Error::input(format!(
            "{name}: region: coordinate ({}, {}) is not lon/lat, but the city is in lon/lat (the region must be in the city's coordinates)",
            p[0], p[1]
        )));
    }
    let local: Vec<model::Ring> = rings
        .iter()
        .map(|ring| ring.iter().map(|p| frame.to_local(p[0], p[1])).collect())
        .collect();
    // The city lies within half its largest extent of the origin; a region
    // reaching much farther out is a mistake (and would make huge grids).
    let reach = assemble::MAX_CITY_EXTENT;
    if let Some((p, q)) = rings
        .iter()
        .flatten()
        .zip(local.iter().flatten())
        .find(|(_, q)| !(q.x.abs() <= reach && q.y.abs() <= reach))
    {
        return Err(crate::Error::input(format!(
            "{name}: region: coordinate ({}, {}) is {:.0} km from the city's centre; a region may reach at most {:.0} km from it",
            p[0],
            p[1],
            q.x.abs().max(q.y.abs()) / 1000.0,
            reach / 1000.0
        )));
    }
    let mut repaired = repair::repair_footprint(&vec![local], false);
    if repaired.footprint.len() != 1 {
        return Err(crate::Error::input(format!(
            "{name}: region: the polygon is not usable ({} pieces after repair{})",
            repaired.footprint.len(),
            if repaired.notes.is_empty() {
                String::new()
            } else {
                format!(": {}", repaired.notes.join("; "))
            }
        )));
    }
    Ok(repaired.footprint.remove(0))
}
