//! Reading cities: GeoJSON, OSM PBF, CityJSON, repairs, hostile input, open-sided structures, generated cities.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

#[path = "../common/mod.rs"]
mod common;
mod generate_city;
mod generate_oldtown;
mod generate_props;
mod input_cityjson;
mod input_errors;
mod input_flags;
mod input_formats;
mod input_geojson;
mod input_hostile;
mod input_large;
mod input_osm;
mod input_repair_props;
mod open_sided;
