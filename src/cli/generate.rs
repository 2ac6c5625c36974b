//! `citypvs generate`: write a procedural city.

use std::path::PathBuf;

use clap::Args;

use crate::Result;
use crate::generate::{GenerateParams, generate_geojson};

#[derive(Args, Debug)]
pub struct GenerateArgs {
    /// Number of buildings.
    #[arg(long, default_value_t = 1000)]
    pub buildings: usize,
    /// Random seed; the same seed gives the same city.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output GeoJSON file.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

pub fn run(args: &GenerateArgs) -> Result<i32> {
    let text = generate_geojson(&GenerateParams {
        buildings: args.buildings,
        seed: args.seed,
    });
    crate::atomic::write_atomically(&args.output, text.as_bytes())?;
    Ok(0)
}
