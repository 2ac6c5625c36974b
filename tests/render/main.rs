//! Pictures.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

#[path = "../common/mod.rs"]
mod common;
mod render_cli;
mod render_hostile;
mod render_pictures;
