//! `citypvs bake`: read (or generate) a city, prepare it, compute every
//! cell's PVS (or one shard's cells), saving checkpoints and resuming from
//! one, write the `.pvs` (or shard) file atomically and print a summary.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use super::common::{CacheArgs, InputArgs, RunArgs, SceneArgs, ViewArgs};
use crate::Result;
use crate::input::{City, read_city, read_city_bytes};
use crate::prepare::StageTime;
use crate::scale::resume::{bake_range, remove_checkpoint};
use crate::scale::shard::{ShardArg, ShardSpec};

/// Buildings in the embedded default city.
pub const DEFAULT_CITY_BUILDINGS: usize = 400;
/// Seed of the embedded default city.
pub const DEFAULT_CITY_SEED: u64 = 1;

#[derive(Args, Debug)]
pub struct BakeArgs {
    /// The city file (GeoJSON, OSM PBF or CityJSON). Without it, an embedded
    /// generated city of 400 buildings (seed 1) is baked.
    pub city: Option<PathBuf>,
    /// Output file [default: the city's name with .pvs, or default-city.pvs].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub view: ViewArgs,
    #[command(flatten)]
    pub run: RunArgs,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Bake only shard K of N (numbered from 0) and write a shard file
    /// [default: CITY.shard-K-of-N] for `citypvs merge`. With auto/N, K is
    /// read from the first of these that is set: JOB_COMPLETION_INDEX
    /// (Kubernetes Indexed Job), SLURM_ARRAY_TASK_ID (Slurm job array),
    /// CITYPVS_SHARD (anything else).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// An earlier bake of this city (same settings, same citypvs): only the
    /// cells whose sets can have changed since are solved, the others are
    /// copied; the file is the same as without --previous.
    #[arg(long, value_name = "OLD.pvs")]
    pub previous: Option<PathBuf>,
    #[command(flatten)]
    pub cache: CacheArgs,
}

/// What `bake --json` prints.
#[derive(serde::Serialize)]
struct Summary<'a> {
    city: String,
    output: String,
    buildings: usize,
    repaired: usize,
    skipped: usize,
    #[serde(flatten)]
    stats: &'a crate::bake::BakeStats,
    file_bytes: u64,
    bytes_per_cell: f64,
    compression: &'a crate::pvs::WriteStats,
    peak_memory_bytes: Option<u64>,
    threads: usize,
    timings: &'a [StageTime],
    /// "K/N" for a shard.
    #[serde(skip_serializing_if = "Option::is_none")]
    shard: Option<String>,
    /// The environment variable K came from (`--shard auto/N`).
    #[serde(skip_serializing_if = "Option::is_none")]
    shard_from: Option<&'static str>,
    /// The cells baked, a range of the whole bake's cell order.
    cell_range: [usize; 2],
    /// Cells whose sets were read from a checkpoint instead of solved.
    cells_from_checkpoint: usize,
    /// Checkpoints saved while baking.
    checkpoints_written: usize,
    /// Cells solved, and cells copied from `--previous`.
    cells_recomputed: usize,
    cells_copied: usize,
    /// What `--previous` changed, when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    rebake: Option<crate::scale::rebake::RebakeStats>,
    /// How `--geometry-cache` was used, when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    geometry_cache: Option<crate::scale::geometry_cache::CacheReport>,
}

fn load_city(args: &BakeArgs) -> Result<(City, String)> {
    match &args.city {
        Some(path) => Ok((
            read_city(path, &args.input.options())?,
            path.display().to_string(),
        )),
        None => {
            // The embedded city is lon/lat GeoJSON with every height given:
            // flags about reading some other file cannot apply to it.
            let input = &args.input;
            for (given, flag) in [
                (input.metric, "--metric"),
                (input.format.is_some(), "--format"),
                (input.default_height.is_some(), "--default-height"),
            ] {
                if given {
                    return Err(crate::Error::usage(format!(
                        "{flag} applies to reading a city file, and none was given (the embedded \
                         default city is lon/lat GeoJSON with every height known)"
                    )));
                }
            }
            let name = format!(
                "<default city: {DEFAULT_CITY_BUILDINGS} generated buildings, seed {DEFAULT_CITY_SEED}>"
            );
            let text = crate::generate::generate_geojson(&crate::generate::GenerateParams {
                buildings: DEFAULT_CITY_BUILDINGS,
                seed: DEFAULT_CITY_SEED,
            });
            Ok((
                read_city_bytes(text.as_bytes(), &name, &args.input.options())?,
                name,
            ))
        }
    }
}

fn city_stem(args: &BakeArgs) -> String {
    match &args.city {
        Some(city) => city
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "city".into()),
        None => "default-city".into(),
    }
}

fn output_path(args: &BakeArgs, shard: Option<ShardSpec>) -> PathBuf {
    if let (None, Some(spec)) = (&args.output, shard) {
        return crate::scale::shard::default_shard_path(&city_stem(args), spec);
    }
    match (&args.output, &args.city) {
        (Some(o), _) => o.clone(),
        (None, Some(city)) => {
            let stem = city
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "city".into());
            Path::new(&format!("{stem}.pvs")).to_path_buf()
        }
        (None, None) => PathBuf::from("default-city.pvs"),
    }
}

pub fn run(args: &BakeArgs) -> Result<i32> {
    let pool = super::common::thread_pool(args.run.threads)?;
    pool.install(|| run_in_pool(args, pool.current_num_threads()))
}

fn run_in_pool(args: &BakeArgs, threads: usize) -> Result<i32> {
    // The shard first: a bad --shard or environment fails before any work.
    let shard = match &args.shard {
        Some(text) => Some(ShardArg::parse(text)?.resolve(|name| std::env::var(name).ok())?),
        None => None,
    };
    if args.previous.is_some() && shard.is_some() {
        return Err(crate::Error::usage(
            "--previous and --shard cannot be combined: bake the whole city with --previous",
        ));
    }
    let output = output_path(args, shard.map(|(s, _)| s));
    let inputs: Vec<&Path> = args
        .city
        .iter()
        .chain(args.scene.region.iter())
        .map(PathBuf::as_path)
        .collect();
    let t = Instant::now();
    let (city, city_name) = load_city(args)?;
    let read_seconds = t.elapsed().as_secs_f64();
    // After reading (a missing input is the first thing to say), before the work.
    crate::atomic::check_output(&output, &inputs)?;
    let others: Vec<&Path> = inputs
        .iter()
        .copied()
        .chain([output.as_path()])
        .chain(args.previous.as_deref())
        .collect();
    args.cache.check(&others)?;
    let settings = super::common::settings(&args.scene, Some(&args.view), &city.frame)?;
    let (scene, geometry_cache) =
        args.cache
            .prepare(city, read_seconds, &settings, &mut |line| {
                eprintln!("{line}")
            })?;

    let engine = crate::visibility::VisibilityEngine::new(&scene)?;
    let cells = scene.cells.triangles.len();
    let mut timings = scene.timings.clone();
    let (spec, range) = match shard {
        Some((spec, _)) => {
            let t = Instant::now();
            let ranges = crate::scale::shard::split(
                &crate::scale::shard::shard_costs(&engine, spec.n),
                spec.n,
            );
            timings.push(StageTime {
                stage: "split",
                seconds: t.elapsed().as_secs_f64(),
            });
            (spec, ranges[spec.k].clone())
        }
        None => (ShardSpec { k: 0, n: 1 }, 0..cells),
    };

    let bar = super::common::progress_bar(args.run.quiet, "cells", range.len() as u64);
    let tick = |n: u64| {
        if let Some(b) = &bar {
            b.inc(n)
        }
    };
    let mut log = |line: String| match &bar {
        Some(b) => b.println(line),
        None => eprintln!("{line}"),
    };
    let (rebaked, rebake) = match &args.previous {
        Some(previous) => {
            let old = crate::pvs::PvsReader::open(previous).map_err(|e| e.context("--previous"))?;
            crate::scale::rebake::check_previous(&scene, &old, previous)?;
            let (baked, stats) = crate::scale::rebake::rebake_all(&scene, &engine, &old, &tick)?;
            (baked, Some(stats))
        }
        None => (None, None),
    };
    // Without --previous, or with one that cannot be used cell by cell: the
    // whole range, streamed and checkpointed as any bake.
    let baked = match rebaked {
        Some(baked) => baked,
        None => bake_range(
            &scene,
            &engine,
            spec,
            range.clone(),
            &output,
            &tick,
            &mut log,
        )?,
    };
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    timings.push(baked.timing.clone());

    let t = Instant::now();
    let write_stats = if shard.is_some() {
        baked.part.write(&output)?;
        crate::pvs::WriteStats {
            file_bytes: std::fs::metadata(&output).map(|m| m.len()).unwrap_or(0),
            ..Default::default()
        }
    } else {
        baked.part.write_pvs(&output)?
    };
    remove_checkpoint(&output)?;
    timings.push(StageTime {
        stage: "write",
        seconds: t.elapsed().as_secs_f64(),
    });

    let stats = &baked.stats;
    let summary = Summary {
        city: city_name,
        output: output.display().to_string(),
        buildings: scene.city.buildings.len(),
        repaired: scene.city.report.repaired.len(),
        skipped: scene.city.report.skipped.len(),
        stats,
        file_bytes: write_stats.file_bytes,
        bytes_per_cell: if stats.cells > 0 {
            write_stats.file_bytes as f64 / stats.cells as f64
        } else {
            0.0
        },
        compression: &write_stats,
        peak_memory_bytes: crate::bake::peak_memory_bytes(),
        threads,
        timings: &timings,
        shard: shard.map(|(s, _)| format!("{}/{}", s.k, s.n)),
        shard_from: shard.and_then(|(_, from)| from),
        cell_range: [range.start, range.end],
        cells_from_checkpoint: baked.cells_from_checkpoint,
        checkpoints_written: baked.checkpoints_written,
        cells_recomputed: rebake
            .as_ref()
            .map_or(range.len() - baked.cells_from_checkpoint, |r| {
                r.cells_recomputed
            }),
        cells_copied: rebake.as_ref().map_or(0, |r| r.cells_copied),
        rebake,
        geometry_cache,
    };
    super::common::print_summary(&[&output], args.json, &summary, |out| {
        print_summary(out, &summary)
    });
    Ok(0)
}

fn print_summary(out: &mut dyn std::io::Write, s: &Summary) {
    say!(out, "baked {} -> {}", s.city, s.output);
    if let Some(shard) = &s.shard {
        say!(
            out,
            "shard          {shard} (cells {}..{})",
            s.cell_range[0],
            s.cell_range[1]
        );
    }
    if let Some(r) = &s.rebake {
        say!(
            out,
            "previous       {} cells copied, {} recomputed",
            r.cells_copied,
            r.cells_recomputed
        );
    }
    if s.cells_from_checkpoint > 0 {
        say!(
            out,
            "resumed        {} cells from the checkpoint",
            s.cells_from_checkpoint
        );
    }
    say!(
        out,
        "buildings      {} ({} repaired, {} skipped)",
        s.buildings,
        s.repaired,
        s.skipped
    );
    say!(out, "cells          {}", s.stats.cells);
    say!(out, "samples        {}", s.stats.samples);
    say!(
        out,
        "visible/cell   mean {:.1}, max {}",
        s.stats.mean_visible,
        s.stats.max_visible
    );
    say!(
        out,
        "culled         {:.1} % of (cell, building) pairs",
        100.0 * s.stats.culled_fraction
    );
    say!(
        out,
        "file           {} bytes ({:.1} bytes per cell)",
        s.file_bytes,
        s.bytes_per_cell
    );
    if let Some(m) = s.peak_memory_bytes {
        say!(
            out,
            "peak memory    {:.1} MiB",
            m as f64 / (1024.0 * 1024.0)
        );
    }
    for t in s.timings {
        say!(out, "time {:<10} {:.2} s", t.stage, t.seconds);
    }
}
