//! The judge: verify.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

#[path = "../common/mod.rs"]
mod common;
mod verify_bake;
mod verify_cli;
mod verify_hostile;
mod verify_judge;
mod verify_odd;
mod verify_speed;
