//! Shards, merge, resume, diff and the batch recipes.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

#[path = "../common/mod.rs"]
mod common;
mod scale_balance;
mod scale_diff;
mod scale_geometry_cache;
mod scale_probe;
mod scale_rebake;
mod scale_recipes;
mod scale_resume;
mod scale_shards;
