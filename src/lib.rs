//! # citypvs
//!
//! Bakes conservative potentially-visible sets (PVS) for cities: for every view
//! cell of the free space between buildings, the set of buildings that may be
//! seen from anywhere inside it. The method and the conditions that make it
//! conservative are described in `docs/DESIGN.md`.
//!
//! The pipeline, one module per stage:
//!
//! | stage | module | what it owns |
//! |---|---|---|
//! | read | [`input`] | GeoJSON / OSM PBF / CityJSON footprints, heights, projection, repair |
//! | merge and shrink | [`geometry`] | blocks of touching buildings as height fields, conservative erosion |
//! | view cells | [`cells`] | constrained Delaunay triangulation of free space |
//! | settings | [`settings`] | every bake number, validated once |
//! | orchestration | [`prepare`] | runs the three stages above and times them |
//! | bake | [`bake`] | runs visibility over a prepared scene and packages the PVS |
//! | visibility | [`visibility`] | samples, cull maps, hierarchical horizon, per-cell PVS |
//! | output | [`pvs`] | the `.pvs` file: format, compression, reading |
//! | judging | [`verify`] | independent dense point-sampling check of conservativeness |
//! | test cities | [`generate`] | procedural cities |
//! | pictures | [`render`] | PNG maps of cities, cells and PVS |
//! | command line | [`cli`] | the `citypvs` subcommands |

pub mod atomic;
pub mod bake;
pub mod cells;
pub mod cli;
pub mod error;
pub mod generate;
pub mod geometry;
pub mod input;
pub mod model;
pub mod prepare;
pub mod pvs;
pub mod render;
pub mod settings;
pub mod verify;
pub mod visibility;

pub use error::{Error, ErrorKind, Result};
pub use settings::{RawSettings, Settings};
