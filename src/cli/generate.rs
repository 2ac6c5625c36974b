//! `citypvs generate`: write a procedural city.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;

use crate::Result;
use crate::generate::{GenerateParams, Style, generate_styled};

/// The largest city the command makes (about 5,000 km^2).
pub const MAX_BUILDINGS: usize = 5_000_000;

#[derive(Args, Debug)]
pub struct GenerateArgs {
    /// Number of buildings (the city grows at about 1,000 buildings per km^2).
    #[arg(long, default_value_t = 1000)]
    pub buildings: usize,
    /// Random seed; the same seed gives the same city.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// The look of the city: `default`, or `old-town` (perimeter blocks of
    /// separate buildings with the misaligned shared walls of real map data).
    #[arg(long, value_enum, default_value_t = Style::Default)]
    pub style: Style,
    /// Output GeoJSON file.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
}

pub fn run(args: &GenerateArgs) -> Result<i32> {
    if args.buildings == 0 || args.buildings > MAX_BUILDINGS {
        return Err(crate::Error::usage(format!(
            "--buildings must be between 1 and {MAX_BUILDINGS}, got {}",
            args.buildings
        )));
    }
    crate::atomic::check_output(&args.output, &[])?;
    let params = GenerateParams {
        buildings: args.buildings,
        seed: args.seed,
    };
    let city = generate_styled(&params, args.style);
    let text = crate::generate::geojson::write_with_decimals(
        &city.buildings,
        &crate::generate::frame(),
        crate::generate::decimals(args.style),
    );
    crate::atomic::write_atomically(&args.output, text.as_bytes())?;
    let extent = crate::model::Rect::of_points(
        city.buildings
            .iter()
            .flat_map(|b| b.footprint.exterior.iter()),
    );
    let mut out = super::common::summary_stream(&[&args.output]);
    say!(
        out,
        "wrote {} buildings to {} ({:.0} m x {:.0} m around lon {}, lat {})",
        city.buildings.len(),
        args.output.display(),
        extent.width(),
        extent.height(),
        crate::generate::ORIGIN_LON,
        crate::generate::ORIGIN_LAT
    );
    Ok(0)
}
