//! The .pvs file: format, reader, C interface, hostile files, inspect.
//!
//! One test binary for the group (each file below is a module), so the
//! suite links a few binaries instead of one per file.

mod capi_reader;
#[path = "../common/mod.rs"]
mod common;
mod pvs_format;
mod pvs_hostile;
mod pvs_inspect;
mod pvs_measure;
mod pvs_v2_measure;
