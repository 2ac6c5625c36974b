//! The command line: argument definitions and one module per subcommand.
//! Each subcommand module owns its arguments and its printing; the work
//! itself is done by the library modules.

/// Print a summary line; a closed stream (e.g. `| head`) is not an error.
macro_rules! say {
    ($out:expr, $($arg:tt)*) => {{
        let _ = writeln!($out, $($arg)*);
    }};
}

pub mod bake;
pub mod bench;
pub mod common;
pub mod generate;
pub mod inspect;
pub mod prepare;
pub mod render;
pub mod verify;

use clap::{Parser, Subcommand};

/// Bake conservative potentially-visible sets (PVS) for cities.
#[derive(Parser, Debug)]
#[command(name = "citypvs", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Write a procedural city as lon/lat GeoJSON.
    Generate(generate::GenerateArgs),
    /// Read a city, merge and shrink footprints, cut free space into view cells, and report.
    Prepare(prepare::PrepareArgs),
    /// Compute every view cell's potentially visible set and write a .pvs file.
    Bake(bake::BakeArgs),
    /// Measure preparation and bake speed on generated cities of several sizes.
    Bench(bench::BenchArgs),
    /// Print a .pvs file's header and statistics, or dump it as JSON.
    Inspect(inspect::InspectArgs),
    /// Check a .pvs file against its city by exact visibility from sampled viewpoints.
    Verify(verify::VerifyArgs),
    /// Draw a PNG map of a city, a cell's visible set, its cull map or every cell's PVS size.
    Render(render::RenderArgs),
}

/// Parse the arguments, run the subcommand, print any error, return the exit status.
pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Generate(args) => generate::run(&args),
        Command::Prepare(args) => prepare::run(&args),
        Command::Bake(args) => bake::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Inspect(args) => inspect::run(&args),
        Command::Verify(args) => verify::run(&args),
        Command::Render(args) => render::run(&args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", e.cli_message());
            2
        }
    }
}
