//! `citypvs bench`: generate cities of several sizes, prepare and bake each,
//! and print the figures (cells, seconds, cells per second, seconds per cell,
//! PVS sizes, bytes per cell). Speed is measured here, never in tests.

use std::time::Instant;

use clap::Args;

use crate::Result;
use crate::input::{InputOptions, read_city_bytes};
use crate::prepare::{PrepareParams, prepare};
use crate::visibility::VisibilityParams;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// City sizes to measure, in buildings.
    #[arg(long, value_delimiter = ',', default_value = "1000,10000")]
    pub buildings: Vec<usize>,
    /// Seed of the generated cities.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Style of the generated cities (`default` or `old-town`).
    #[arg(long, value_enum, default_value_t = crate::generate::Style::Default)]
    pub style: crate::generate::Style,
    /// Worker threads [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Print one JSON object per city instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Figures for one city.
#[derive(serde::Serialize)]
struct Row {
    buildings: usize,
    cells: usize,
    samples: usize,
    prepare_seconds: f64,
    bake_seconds: f64,
    cells_per_second: f64,
    micros_per_cell: f64,
    mean_visible: f64,
    max_visible: usize,
    culled_fraction: f64,
    file_bytes: u64,
    bytes_per_cell: f64,
    raw_bitset_bytes_per_cell: f64,
    rle_bitset_bytes_per_cell: f64,
    peak_memory_bytes_so_far: Option<u64>,
}

pub fn run(args: &BenchArgs) -> Result<i32> {
    let pool = super::common::thread_pool(args.threads)?;
    if !args.json {
        println!(
            "{:>9} {:>8} {:>9} {:>9} {:>9} {:>10} {:>9} {:>8} {:>7} {:>9}",
            "buildings",
            "cells",
            "prepare s",
            "bake s",
            "cells/s",
            "us/cell",
            "mean PVS",
            "culled",
            "B/cell",
            "peak MiB"
        );
    }
    let dir = tempfile::tempdir()
        .map_err(|e| crate::Error::new(format!("cannot make a temporary folder: {e}")))?;
    for &n in &args.buildings {
        let text = crate::generate::generate_geojson_styled(
            &crate::generate::GenerateParams {
                buildings: n,
                seed: args.seed,
            },
            args.style,
        );
        let city = read_city_bytes(
            text.as_bytes(),
            &format!("<generated {n}>"),
            &InputOptions::default(),
        )?;
        let params = PrepareParams::default();
        let t = Instant::now();
        let scene = prepare(city, &params)?;
        let prepare_seconds = t.elapsed().as_secs_f64();
        let vis = VisibilityParams::for_eps(params.eps);
        let t = Instant::now();
        let (data, stats, _) = pool.install(|| {
            crate::bake::bake(
                &scene,
                &vis,
                params.cells.max_edge,
                params.cells.margin,
                &|_| {},
            )
        })?;
        let bake_seconds = t.elapsed().as_secs_f64();
        let written = crate::pvs::write_pvs(&dir.path().join(format!("bench-{n}.pvs")), &data)?;
        let cells = stats.cells.max(1) as f64;
        let row = Row {
            buildings: n,
            cells: stats.cells,
            samples: stats.samples,
            prepare_seconds,
            bake_seconds,
            cells_per_second: stats.cells as f64 / bake_seconds,
            micros_per_cell: 1e6 * bake_seconds / cells,
            mean_visible: stats.mean_visible,
            max_visible: stats.max_visible,
            culled_fraction: stats.culled_fraction,
            file_bytes: written.file_bytes,
            bytes_per_cell: written.file_bytes as f64 / cells,
            raw_bitset_bytes_per_cell: written.raw_bitset_bytes as f64 / cells,
            rle_bitset_bytes_per_cell: written.rle_bitset_bytes as f64 / cells,
            peak_memory_bytes_so_far: crate::bake::peak_memory_bytes(),
        };
        if args.json {
            println!("{}", serde_json::to_string(&row).expect("row serialises"));
        } else {
            println!(
                "{:>9} {:>8} {:>9.2} {:>9.2} {:>9.0} {:>10.0} {:>9.1} {:>7.1}% {:>7.1} {:>9.0}",
                row.buildings,
                row.cells,
                row.prepare_seconds,
                row.bake_seconds,
                row.cells_per_second,
                row.micros_per_cell,
                row.mean_visible,
                100.0 * row.culled_fraction,
                row.bytes_per_cell,
                row.peak_memory_bytes_so_far.unwrap_or(0) as f64 / 1048576.0
            );
        }
    }
    Ok(0)
}
