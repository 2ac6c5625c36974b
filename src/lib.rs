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
//! | frames | [`frame`] | local metres to and from the input's coordinates |
//! | GeoJSON out | [`export`] | the one GeoJSON writer (test cities, cell and occluder exports) |
//! | judging | [`verify`] | independent dense point-sampling check of conservativeness |
//! | test cities | [`generate`] | procedural cities |
//! | pictures | [`render`] | PNG maps of cities, cells and PVS |
//! | scale-out | [`scale`] | shards, merge, checkpoints and resume, diff of two `.pvs` files |
//! | command line | [`cli`] | the `citypvs` subcommands |
//!
//! Reading `.pvs` files needs only [`pvs`], [`frame`], [`atomic`] and
//! [`error`]: `cargo build --no-default-features` builds just those (the
//! `bake` feature, on by default, brings the rest); the `capi` feature adds
//! the C ABI reader `capi` (header `include/citypvs.h`).

pub mod atomic;
#[cfg(feature = "bake")]
pub mod bake;
#[cfg(feature = "capi")]
pub mod capi;
#[cfg(feature = "bake")]
pub mod cells;
#[cfg(feature = "bake")]
pub mod cli;
pub mod error;
#[cfg(feature = "bake")]
pub mod export;
pub mod frame;
#[cfg(feature = "bake")]
pub mod generate;
#[cfg(feature = "bake")]
pub mod geometry;
pub mod grid;
pub mod infile;
#[cfg(feature = "bake")]
pub mod input;
pub mod model;
#[cfg(feature = "bake")]
pub mod prepare;
pub mod pvs;
#[cfg(feature = "bake")]
pub mod render;
#[cfg(feature = "bake")]
pub mod scale;
pub mod settings;
#[cfg(feature = "bake")]
pub mod verify;
#[cfg(feature = "bake")]
pub mod visibility;

pub use error::{Error, ErrorKind, Result};
pub use settings::{BakeNumbers, RawSettings, Settings};
