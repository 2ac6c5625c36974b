//! `citypvs bench`: generate cities of several sizes, prepare and bake each,
//! and print the figures (cells, seconds, cells per second, seconds per cell,
//! visible cell-building pairs per second, PVS sizes, bytes per cell), then
//! how each larger city's speed compares with the smallest one's. With
//! `--repeat N` the cities are baked in N rounds (each city once a round)
//! and the run of median wall time stands for each, with the spread beside
//! it, so that a change of a few per cent is not lost in one noisy run.
//! Speed is measured here, never in tests.

use std::time::Instant;

use clap::Args;

use crate::Result;
use crate::input::{InputOptions, read_city_bytes};
use crate::prepare::prepare;
use crate::scale::resume::{bake_range, remove_checkpoint};
use crate::scale::shard::ShardSpec;
use crate::settings::Settings;

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
    /// Bake each city this many times, in rounds (each city once a round,
    /// so a machine whose speed drifts touches all cities alike), and report
    /// the run of median wall time with the fastest and slowest beside it
    /// (every run must write the same bytes).
    #[arg(long, value_name = "N", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=MAX_REPEAT as i64))]
    pub repeat: u32,
    /// Print one JSON object per city instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Save the figures to this JSON file, to compare later runs against.
    #[arg(long, value_name = "FILE")]
    pub save: Option<std::path::PathBuf>,
    /// Compare with the figures saved by an earlier `bench --save FILE`:
    /// prints both runs side by side with their ratio.
    #[arg(long, value_name = "FILE")]
    pub baseline: Option<std::path::PathBuf>,
}

/// The most bakes of one city `--repeat` asks for.
const MAX_REPEAT: u32 = 100;

/// Figures for one city.
#[derive(serde::Serialize, serde::Deserialize, Clone, Debug)]
struct Row {
    buildings: usize,
    cells: usize,
    samples: usize,
    prepare_seconds: f64,
    bake_seconds: f64,
    cells_per_second: f64,
    micros_per_cell: f64,
    /// How many times the city was baked; the figures are those of the run
    /// of median wall time (1 in runs saved by older versions).
    #[serde(default = "one_run")]
    runs: u32,
    /// The fastest and slowest of those runs' wall times (0 in runs saved
    /// by older versions).
    #[serde(default)]
    bake_seconds_min: f64,
    #[serde(default)]
    bake_seconds_max: f64,
    /// CPU seconds (user and system, all threads) of the median run's bake,
    /// and per cell (a wall time well above the CPU time over the threads
    /// shows a run that waited for its cores). 0 where the OS does not
    /// tell, and in older saved runs.
    #[serde(default)]
    cpu_seconds: f64,
    #[serde(default)]
    cpu_micros_per_cell: f64,
    /// Visible (cell, building) pairs written per second of the bake: the
    /// work of a sample grows with what it sees, so this figure stays
    /// nearly flat as a city grows when cells per second falls because
    /// its cells see more. Absent (0) in runs saved by older versions.
    #[serde(default)]
    visible_pairs_per_second: f64,
    mean_visible: f64,
    max_visible: usize,
    culled_fraction: f64,
    file_bytes: u64,
    bytes_per_cell: f64,
    raw_bitset_bytes_per_cell: f64,
    rle_bitset_bytes_per_cell: f64,
    peak_memory_bytes_so_far: Option<u64>,
}

fn one_run() -> u32 {
    1
}

/// What `--save` writes.
#[derive(serde::Serialize, serde::Deserialize)]
struct Saved {
    tool_version: String,
    seed: u64,
    threads: usize,
    rows: Vec<Row>,
}

fn read_baseline(path: &std::path::Path) -> Result<Saved> {
    let starts_right = |b: &[u8]| b.trim_ascii_start().starts_with(b"{");
    let text = crate::infile::read_whole(path, starts_right, "a saved bench run")?;
    serde_json::from_slice(&text).map_err(|e| {
        crate::Error::input(format!(
            "{}: not a file written by `citypvs bench --save`: {e}",
            path.display()
        ))
    })
}

/// The figures compared with a baseline, and whether lower is better.
const COMPARED: [(&str, bool); 8] = [
    ("bake_seconds", true),
    ("cpu_seconds", true),
    ("cells_per_second", false),
    ("visible_pairs_per_second", false),
    ("mean_visible", true),
    ("bytes_per_cell", true),
    ("peak_memory_bytes_so_far", true),
    ("cells", true),
];

fn figure(row: &Row, name: &str) -> f64 {
    match name {
        "bake_seconds" => row.bake_seconds,
        "cpu_seconds" => row.cpu_seconds,
        "cells_per_second" => row.cells_per_second,
        "visible_pairs_per_second" => row.visible_pairs_per_second,
        "mean_visible" => row.mean_visible,
        "bytes_per_cell" => row.bytes_per_cell,
        "peak_memory_bytes_so_far" => row.peak_memory_bytes_so_far.unwrap_or(0) as f64 / 1048576.0,
        _ => row.cells as f64,
    }
}

/// Print this run beside the baseline's row for the same city size.
fn print_comparison(base: &Saved, row: &Row) {
    let Some(old) = base.rows.iter().find(|r| r.buildings == row.buildings) else {
        println!("  (no baseline figures for {} buildings)", row.buildings);
        return;
    };
    println!(
        "  {:<26} {:>12} {:>12} {:>8}",
        format!("{} buildings vs baseline", row.buildings),
        "baseline",
        "now",
        "now/base"
    );
    for (name, lower_is_better) in COMPARED {
        let (a, b) = (figure(old, name), figure(row, name));
        let label = if name == "peak_memory_bytes_so_far" {
            "peak_memory_mib"
        } else {
            name
        };
        if a == 0.0 {
            // A figure the baseline's version did not record.
            println!("  {label:<26} {:>12} {b:>12.2} {:>8}", "-", "-");
            continue;
        }
        let ratio = b / a;
        let worse = if lower_is_better {
            ratio > 1.05
        } else {
            ratio < 0.95
        };
        println!(
            "  {label:<26} {a:>12.2} {b:>12.2} {ratio:>7.2}x{}",
            if worse { "  (worse)" } else { "" }
        );
    }
}

/// How each larger city's speed compares with the smallest city's of this
/// run: the ratio of cells per second, and of visible pairs per second.
fn print_scaling(rows: &[Row], json: bool) {
    let Some(small) = rows.iter().min_by_key(|r| r.buildings) else {
        return;
    };
    for row in rows.iter().filter(|r| r.buildings > small.buildings) {
        let cells = row.cells_per_second / small.cells_per_second;
        let pairs = row.visible_pairs_per_second / small.visible_pairs_per_second;
        // Cells per CPU second, where both runs tell their CPU time.
        let cpu = (row.cpu_micros_per_cell > 0.0 && small.cpu_micros_per_cell > 0.0)
            .then(|| small.cpu_micros_per_cell / row.cpu_micros_per_cell);
        if json {
            println!(
                "{}",
                serde_json::json!({
                    "buildings": row.buildings,
                    "against_buildings": small.buildings,
                    "cells_per_second_ratio": cells,
                    "visible_pairs_per_second_ratio": pairs,
                    "cells_per_cpu_second_ratio": cpu,
                })
            );
        } else {
            let cpu = cpu.map_or(String::new(), |r| format!(", cells per CPU second {r:.2}x"));
            println!(
                "  {} against {} buildings: cells/s {:.2}x{cpu}, visible pairs/s {:.2}x (mean PVS {:.1} against {:.1})",
                row.buildings, small.buildings, cells, pairs, row.mean_visible, small.mean_visible
            );
        }
    }
}

pub fn run(args: &BenchArgs) -> Result<i32> {
    let max = super::generate::MAX_BUILDINGS;
    if let Some(&n) = args.buildings.iter().find(|&&n| n == 0 || n > max) {
        return Err(crate::Error::usage(format!(
            "--buildings must be between 1 and {max}, got {n}"
        )));
    }
    let pool = super::common::thread_pool(args.threads)?;
    let baseline = match &args.baseline {
        Some(p) => Some(read_baseline(p)?),
        None => None,
    };
    let mut rows = Vec::new();
    if !args.json {
        println!(
            "{:>9} {:>8} {:>9} {:>9} {:>9} {:>9} {:>10} {:>9} {:>9} {:>8} {:>7} {:>9}",
            "buildings",
            "cells",
            "prepare s",
            "bake s",
            "CPU s",
            "cells/s",
            "us/cell",
            "pairs/s",
            "mean PVS",
            "culled",
            "B/cell",
            "peak MiB"
        );
    }
    let dir = tempfile::tempdir()
        .map_err(|e| crate::Error::io(format!("cannot make a temporary folder: {e}")))?;
    // With `--repeat`, the cities are baked in rounds (each city once per
    // round, in the order given), so that a machine that slows down or
    // speeds up over the minutes of a bench touches every city alike and
    // the ratios between them hold. A city's row is printed after its last
    // run; its scene is kept until then.
    let mut cities: Vec<CityRuns> = Vec::new();
    for round in 0..args.repeat {
        for (i, &n) in args.buildings.iter().enumerate() {
            if round == 0 {
                cities.push(CityRuns::prepare(n, args, &pool)?);
            }
            let city = &mut cities[i];
            let output = dir.path().join(format!("bench-{n}.pvs"));
            let scene = city.scene.as_ref().expect("kept until the city's last run");
            let run = pool.install(|| bake_once(scene, &output))?;
            if args.repeat > 1 {
                eprintln!(
                    "bench: {n} buildings, run {} of {}: {:.2} s",
                    round + 1,
                    args.repeat,
                    run.seconds
                );
            }
            city.add(run)?;
            if round + 1 == args.repeat {
                city.scene = None;
                let row = city.row();
                print_row(&row, baseline.as_ref(), args.json);
                rows.push(row);
            }
        }
    }
    print_scaling(&rows, args.json);
    if let Some(path) = &args.save {
        let saved = Saved {
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
            seed: args.seed,
            threads: pool.current_num_threads(),
            rows,
        };
        let text = serde_json::to_string_pretty(&saved).expect("figures serialise");
        crate::atomic::write_atomically(path, text.as_bytes())?;
    }
    Ok(0)
}

/// A generated city being measured: its scene (until its last run), the
/// time it took to prepare, and its runs so far.
struct CityRuns {
    buildings: usize,
    scene: Option<crate::prepare::Scene>,
    prepare_seconds: f64,
    runs: Vec<Run>,
    /// The peak as the first bake leaves it: later runs can raise the
    /// process's high-water mark by how the allocator reuses what the first
    /// one freed.
    peak_after_first: Option<u64>,
}

impl CityRuns {
    /// Generate the city of `n` buildings and prepare its scene.
    fn prepare(n: usize, args: &BenchArgs, pool: &rayon::ThreadPool) -> Result<Self> {
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
        let t = Instant::now();
        let scene = pool.install(|| prepare(city, &Settings::default()))?;
        Ok(CityRuns {
            buildings: n,
            scene: Some(scene),
            prepare_seconds: t.elapsed().as_secs_f64(),
            runs: Vec::new(),
            peak_after_first: None,
        })
    }

    /// Keep one more run; every run must have written the first one's bytes.
    fn add(&mut self, run: Run) -> Result<()> {
        match self.runs.first() {
            None => self.peak_after_first = crate::bake::peak_memory_bytes(),
            Some(first) if first.written.checksum != run.written.checksum => {
                return Err(crate::Error::mismatch(format!(
                    "bench: two bakes of the generated {}-building city wrote different bytes",
                    self.buildings
                )));
            }
            Some(_) => {}
        }
        self.runs.push(run);
        Ok(())
    }

    /// The figures of the run of median wall time, with the spread of all.
    fn row(&mut self) -> Row {
        self.runs.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let (fastest, slowest) = (&self.runs[0], &self.runs[self.runs.len() - 1]);
        let median = &self.runs[(self.runs.len() - 1) / 2];
        let (bake_seconds, stats, written) = (median.seconds, &median.stats, &median.written);
        let cells = stats.cells.max(1) as f64;
        let cpu_seconds = median.cpu_seconds.unwrap_or(0.0);
        Row {
            buildings: self.buildings,
            cells: stats.cells,
            samples: stats.samples,
            prepare_seconds: self.prepare_seconds,
            bake_seconds,
            cells_per_second: stats.cells as f64 / bake_seconds,
            micros_per_cell: 1e6 * bake_seconds / cells,
            runs: self.runs.len() as u32,
            bake_seconds_min: fastest.seconds,
            bake_seconds_max: slowest.seconds,
            cpu_seconds,
            cpu_micros_per_cell: 1e6 * cpu_seconds / cells,
            visible_pairs_per_second: stats.mean_visible * stats.cells as f64 / bake_seconds,
            mean_visible: stats.mean_visible,
            max_visible: stats.max_visible,
            culled_fraction: stats.culled_fraction,
            file_bytes: written.file_bytes,
            bytes_per_cell: written.file_bytes as f64 / cells,
            raw_bitset_bytes_per_cell: written.raw_bitset_bytes as f64 / cells,
            rle_bitset_bytes_per_cell: written.rle_bitset_bytes as f64 / cells,
            peak_memory_bytes_so_far: self.peak_after_first,
        }
    }
}

/// Print a city's row (a table line or a JSON object) and, with a
/// baseline, its figures beside the baseline's.
fn print_row(row: &Row, baseline: Option<&Saved>, json: bool) {
    if json {
        println!("{}", serde_json::to_string(row).expect("row serialises"));
    } else {
        println!(
            "{:>9} {:>8} {:>9.2} {:>9.2} {:>9.2} {:>9.0} {:>10.0} {:>9.0} {:>9.1} {:>7.1}% {:>7.1} {:>9.0}",
            row.buildings,
            row.cells,
            row.prepare_seconds,
            row.bake_seconds,
            row.cpu_seconds,
            row.cells_per_second,
            row.micros_per_cell,
            row.visible_pairs_per_second,
            row.mean_visible,
            100.0 * row.culled_fraction,
            row.bytes_per_cell,
            row.peak_memory_bytes_so_far.unwrap_or(0) as f64 / 1048576.0
        );
        if row.runs > 1 {
            println!(
                "{:>9} {} runs: bake s {:.2} (median), {:.2} to {:.2}",
                "", row.runs, row.bake_seconds, row.bake_seconds_min, row.bake_seconds_max
            );
        }
    }
    let Some(base) = baseline else {
        return;
    };
    if json {
        let old = base.rows.iter().find(|r| r.buildings == row.buildings);
        let ratios: serde_json::Map<String, serde_json::Value> = COMPARED
            .iter()
            .filter_map(|&(name, _)| {
                let a = figure(old?, name);
                (a != 0.0).then(|| (name.to_string(), (figure(row, name) / a).into()))
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({ "buildings": row.buildings, "baseline": old, "ratio_now_to_baseline": ratios })
        );
    } else {
        print_comparison(base, row);
    }
}

/// One bake of a prepared city, as `bench` times it.
struct Run {
    seconds: f64,
    cpu_seconds: Option<f64>,
    stats: crate::bake::BakeStats,
    /// Its sizes and checksum, with which repeated runs are checked to
    /// write the same bytes.
    written: crate::pvs::WriteStats,
}

/// The bake `citypvs bake` runs (the engine, the sets kept compressed with
/// checkpoints, the file written one set at a time), so its time and peak
/// memory are the command's; the file and checkpoint are removed after.
fn bake_once(scene: &crate::prepare::Scene, output: &std::path::Path) -> Result<Run> {
    let t = Instant::now();
    let cpu = crate::bake::cpu_seconds();
    let baked = {
        let engine = crate::visibility::VisibilityEngine::new(scene)?;
        bake_range(
            scene,
            &engine,
            ShardSpec { k: 0, n: 1 },
            0..scene.cells.triangles.len(),
            output,
            &|_| {},
            &mut |_| {},
        )?
    };
    let seconds = t.elapsed().as_secs_f64();
    let cpu_seconds = cpu.zip(crate::bake::cpu_seconds()).map(|(a, b)| b - a);
    let written = baked.part.write_pvs(output)?;
    remove_checkpoint(output)?;
    std::fs::remove_file(output)
        .map_err(|e| crate::Error::io(format!("{}: cannot remove: {e}", output.display())))?;
    Ok(Run {
        seconds,
        cpu_seconds,
        stats: baked.stats,
        written,
    })
}
