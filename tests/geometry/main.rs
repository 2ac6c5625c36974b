//! Merging, shrinking and cutting into cells.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

mod cells_basic;
mod cells_cache;
mod cells_narrow;
mod cells_props;
mod cells_tiles;
#[path = "../common/mod.rs"]
mod common;
mod geometry_basic;
mod geometry_kotka;
mod geometry_props;
mod geometry_robustness;
mod geometry_timing;
#[path = "../geometry_scenes/mod.rs"]
mod scenes;
