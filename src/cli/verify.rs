//! `citypvs verify`: read a city and a `.pvs` baked from it, judge sampled
//! cells with the independent point-visibility check, print the verdict and
//! exit 1 when some building seen from a cell is missing from its PVS.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use super::common::{InputArgs, RunArgs};
use crate::input::read_city;
use crate::pvs::PvsReader;
use crate::verify::{
    DEFAULT_CELLS, DEFAULT_SAMPLES, DEFAULT_SEED, FileCheck, FileUnderTest, VerifyOptions,
    VerifyReport, verify_file,
};
use crate::{Error, Result};

/// Most viewpoints per cell `--samples` accepts (each batch of viewpoints is
/// held in memory; 100,000 per cell already takes hours over 200 cells).
pub const MAX_SAMPLES: usize = 100_000;

#[derive(Args, Debug)]
pub struct VerifyArgs {
    /// The city file the PVS was baked from.
    pub city: PathBuf,
    /// The .pvs file to check.
    pub pvs: PathBuf,
    #[command(flatten)]
    pub input: InputArgs,
    /// Number of cells to check, drawn at random.
    #[arg(long, value_name = "K", default_value_t = DEFAULT_CELLS, conflicts_with = "all")]
    pub cells: usize,
    /// Check every cell.
    #[arg(long)]
    pub all: bool,
    /// Viewpoints per cell: top corners, top edges, inside, and lower down.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_SAMPLES)]
    pub samples: usize,
    /// Seed for choosing cells and viewpoints.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    #[command(flatten)]
    pub run: RunArgs,
    /// Print everything as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// The region file the bake was given with --region (the cells are
    /// compared with the ones prepared for the city with it).
    #[arg(long, value_name = "FILE", conflicts_with = "any_cells")]
    pub region: Option<PathBuf>,
    /// Judge the file's cells as they are, without checking that they are
    /// the cells citypvs prepares for this city with the file's settings
    /// (for PVS files made by hand or by another tool). Not with --region,
    /// which only serves that check.
    #[arg(long)]
    pub any_cells: bool,
}

/// What `verify --json` prints.
#[derive(Serialize)]
struct Verdict<'a> {
    city: String,
    pvs: String,
    /// True when the city file's SHA-256 equals the one stored in the PVS.
    source_matches: bool,
    /// True when the file's cells were found to be the ones prepared for
    /// the city (false with --any-cells: they were judged as they are).
    cells_match_city: bool,
    /// The local frame all coordinates below are in.
    frame: String,
    buildings: usize,
    threads: usize,
    passed: bool,
    #[serde(flatten)]
    report: &'a VerifyReport,
}

pub fn run(args: &VerifyArgs) -> Result<i32> {
    if args.samples == 0 || args.samples > MAX_SAMPLES {
        return Err(Error::usage(format!(
            "--samples must be between 1 and {MAX_SAMPLES} viewpoints per cell, got {}",
            args.samples
        )));
    }
    if args.cells == 0 && !args.all {
        return Err(Error::usage("--cells must be at least 1"));
    }
    let pool = super::common::thread_pool(args.run.threads)?;
    pool.install(|| run_in_pool(args, pool.current_num_threads()))
}

fn run_in_pool(args: &VerifyArgs, threads: usize) -> Result<i32> {
    let city = read_city(&args.city, &args.input.options())?;
    let pvs_name = args.pvs.display().to_string();
    let city_name = args.city.display().to_string();
    let reader = PvsReader::open(&args.pvs)?;
    let info = reader.info();
    let region = match &args.region {
        Some(path) => Some(crate::input::read_region(path, &city.frame)?),
        None => None,
    };
    let options = VerifyOptions {
        cells: if args.all { None } else { Some(args.cells) },
        samples: args.samples,
        seed: args.seed,
    };
    let checked = options
        .cells
        .map_or(reader.cell_count(), |k| k.min(reader.cell_count()));
    let bar = super::common::progress_bar(
        args.run.quiet,
        "viewpoints",
        (checked * args.samples) as u64,
    );
    let tick = |n: u64| {
        if let Some(b) = &bar {
            b.inc(n)
        }
    };
    let file = FileUnderTest {
        city: &city,
        city_name: &city_name,
        reader: &reader,
        pvs_name: &pvs_name,
    };
    let check = FileCheck {
        options,
        cells_must_match: !args.any_cells,
        region,
    };
    let report = verify_file(&file, check, &tick);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let report = report?;
    let passed = report.passed();
    let verdict = Verdict {
        city: args.city.display().to_string(),
        pvs: pvs_name,
        source_matches: info.source_hash == city.source_hash,
        cells_match_city: !args.any_cells,
        frame: info.frame.describe(),
        buildings: city.buildings.len(),
        threads,
        passed,
        report: &report,
    };
    if !verdict.source_matches {
        eprintln!(
            "warning: {} is not the file {} was baked from (SHA-256 differs)",
            verdict.city, verdict.pvs
        );
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&verdict).expect("verdict serialises")
        );
    } else {
        print_table(&verdict);
    }
    Ok(if passed { 0 } else { 1 })
}

fn print_table(v: &Verdict) {
    let r = v.report;
    println!("verified {} against {}", v.pvs, v.city);
    println!(
        "cells          {} of {} (seed {})",
        r.cells_checked, r.cells_total, r.seed
    );
    println!(
        "viewpoints     {} ({} per cell, eye height {} m)",
        r.viewpoints, r.samples_per_cell, r.eye_height
    );
    println!(
        "tightness      mean {:.2}, worst {:.2} (|PVS| / buildings seen)",
        r.mean_tightness, r.worst_tightness
    );
    println!(
        "PVS seen       {:.1} % of the checked cells' PVS entries",
        100.0 * r.seen_fraction
    );
    println!("rays           {}", r.rays);
    println!("time           {:.2} s ({} threads)", r.seconds, v.threads);
    if !r.blocked_viewpoints.is_empty() {
        let b = &r.blocked_viewpoints[0];
        println!(
            "not judged     {} viewpoints inside buildings, e.g. in cell {}, {:.3} m inside {}",
            r.blocked_viewpoints.len(),
            b.cell,
            b.depth,
            b.building
        );
    }
    println!("violations     {}", r.violations.len());
    for x in &r.violations {
        println!(
            "  cell {} misses {}: seen from ({:.3}, {:.3}, {:.3}) at ({:.3}, {:.3}, {:.3})",
            x.cell,
            x.building,
            x.viewpoint[0],
            x.viewpoint[1],
            x.viewpoint[2],
            x.witness[0],
            x.witness[1],
            x.witness[2]
        );
    }
    println!("{}", if v.passed { "PASS" } else { "FAIL" });
}
