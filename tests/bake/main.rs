//! The bake end to end: visibility, settings, the command, output files.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

mod bake_cli;
mod bench_cli;
#[path = "../common/mod.rs"]
mod common;
mod flags_refused;
mod index_limits;
mod output_files;
mod settings_cli;
mod skip_hidden;
mod tiny_buildings;
mod tiny_opening;
mod visibility_cases;
mod visibility_runs;
