//! Arguments shared by several subcommands (input reading, scene preparation)
//! and the helpers that turn them into library parameters.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;

use crate::Result;
use crate::input::{DEFAULT_HEIGHT, Format, InputOptions};
use crate::settings::{RawSettings, Settings};

/// How to read the city file.
/// How a long command runs: its threads and its progress bar.
#[derive(Args, Debug, Clone, Default)]
pub struct RunArgs {
    /// Worker threads [default: all cores]. The result is the same for any number.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug, Clone)]
pub struct InputArgs {
    /// GeoJSON coordinates are metres, used as they are, instead of lon/lat
    /// (OSM PBF is always lon/lat; CityJSON always metres).
    #[arg(long)]
    pub metric: bool,
    /// Height in metres for buildings with no height or level tags
    /// (GeoJSON and OSM PBF; CityJSON heights come from its geometry) [default: 9].
    #[arg(long, value_name = "METRES")]
    pub default_height: Option<f64>,
    /// Turn every warning about repaired or skipped features into an error.
    #[arg(long)]
    pub strict: bool,
    /// Input format (default: from the extension, then the content).
    #[arg(long, value_enum)]
    pub format: Option<Format>,
}

impl InputArgs {
    pub fn options(&self) -> InputOptions {
        InputOptions {
            metric: self.metric,
            default_height: self.default_height.unwrap_or(DEFAULT_HEIGHT),
            default_height_given: self.default_height.is_some(),
            strict: self.strict,
            format: self.format,
        }
    }
}

/// How to merge, shrink and cut the city into cells. Every value left out
/// takes the default of [`crate::settings`].
#[derive(Args, Debug, Clone, Default)]
pub struct SceneArgs {
    /// Erosion distance eps in metres; sample spacing and pixel size follow from it [default: 1].
    #[arg(long, value_name = "METRES")]
    pub eps: Option<f64>,
    /// Longest allowed view-cell edge in metres [default: 30].
    #[arg(long, value_name = "METRES")]
    pub max_cell_edge: Option<f64>,
    /// Margin in metres added around the footprints' bounding box [default: 50].
    #[arg(long, value_name = "METRES")]
    pub margin: Option<f64>,
    /// Narrowest gap in metres a viewer can stand in: free space narrower
    /// than this gets no cells (occluders are unchanged); 0 keeps every gap [default: 0.5].
    #[arg(long, value_name = "METRES")]
    pub min_gap: Option<f64>,
    /// A GeoJSON polygon (in the city's frame) to use as region of interest.
    #[arg(long, value_name = "FILE")]
    pub region: Option<PathBuf>,
}

/// Where preparation keeps its geometry for the next run.
#[derive(Args, Debug, Clone, Default)]
pub struct CacheArgs {
    /// Keep this run's shrunk footprints and opened free space in FILE, and
    /// take from it those of an earlier run (of this city or an edited one)
    /// whose inputs are unchanged, so that preparing an edited city redoes
    /// only what the edit touched. The result is the same as without; a
    /// FILE that cannot be used is reported and rewritten.
    #[arg(long, value_name = "FILE")]
    pub geometry_cache: Option<PathBuf>,
}

impl CacheArgs {
    /// Prepare `city`, through the cache if one was given.
    pub fn prepare(
        &self,
        city: crate::input::City,
        read_seconds: f64,
        settings: &Settings,
        warn: &mut dyn FnMut(String),
    ) -> Result<(
        crate::prepare::Scene,
        Option<crate::scale::geometry_cache::CacheReport>,
    )> {
        match &self.geometry_cache {
            Some(path) => {
                let (scene, report) = crate::scale::geometry_cache::prepare_cached(
                    path,
                    city,
                    read_seconds,
                    settings,
                    warn,
                )?;
                Ok((scene, Some(report)))
            }
            None => {
                let memo = crate::geometry::memo::ShapeMemo::off();
                let scene = crate::prepare::prepare_read(city, read_seconds, settings, &memo)?;
                Ok((scene, None))
            }
        }
    }

    /// The cache may not be one of the command's inputs or outputs.
    pub fn check(&self, others: &[&std::path::Path]) -> Result<()> {
        let Some(cache) = &self.geometry_cache else {
            return Ok(());
        };
        if crate::atomic::is_stdout(cache) {
            return Err(crate::Error::usage(
                "--geometry-cache must name a file, not standard output",
            ));
        }
        // A folder, or a folder that does not exist, first; then whether it
        // is one of the others (by name, or the same file by any name).
        crate::atomic::check_output(cache, &[])?;
        if others.contains(&cache.as_path()) || crate::atomic::check_output(cache, others).is_err()
        {
            return Err(crate::Error::usage(format!(
                "--geometry-cache {} names a file the command reads or writes",
                cache.display()
            )));
        }
        Ok(())
    }
}

/// How the bake looks from each cell. Every value left out takes the
/// default of [`crate::settings`].
#[derive(Args, Debug, Clone, Default)]
pub struct ViewArgs {
    /// Eye height in metres: view cells are prisms from the ground to this height [default: 1.7].
    #[arg(long, value_name = "METRES")]
    pub eye_height: Option<f64>,
    /// Cull-map pixel size in metres [default: (eps - 0.0055) * sqrt(2), the largest with pixel * sqrt(2) / 2 <= eps - 0.0055].
    #[arg(long, value_name = "METRES")]
    pub pixel: Option<f64>,
    /// Half-size in metres of the near-field cull map drawn around each sample [default: 48].
    #[arg(long, value_name = "METRES")]
    pub near_field: Option<f64>,
}

impl SceneArgs {
    /// The flags of this group that were given, as `--name`.
    pub fn given(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.eps.is_some() {
            out.push("--eps");
        }
        if self.max_cell_edge.is_some() {
            out.push("--max-cell-edge");
        }
        if self.margin.is_some() {
            out.push("--margin");
        }
        if self.min_gap.is_some() {
            out.push("--min-gap");
        }
        out
    }

    /// The region polygon in local metres, if one was given.
    pub fn region(&self, frame: &crate::input::Frame) -> Result<Option<crate::model::Polygon>> {
        match &self.region {
            Some(path) => Ok(Some(crate::input::read_region(path, frame)?)),
            None => Ok(None),
        }
    }
}

impl ViewArgs {
    /// The flags of this group that were given, as `--name`.
    pub fn given(&self) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.eye_height.is_some() {
            out.push("--eye-height");
        }
        if self.pixel.is_some() {
            out.push("--pixel");
        }
        if self.near_field.is_some() {
            out.push("--near-field");
        }
        out
    }
}

/// Validate the scene (and view) flags once into the settings; reads the
/// region file if any.
pub fn settings(
    scene: &SceneArgs,
    view: Option<&ViewArgs>,
    frame: &crate::input::Frame,
) -> Result<Settings> {
    let view = view.cloned().unwrap_or_default();
    Settings::new(RawSettings {
        eps: scene.eps,
        pixel: view.pixel,
        eye_height: view.eye_height,
        max_cell_edge: scene.max_cell_edge,
        margin: scene.margin,
        near_field: view.near_field,
        min_gap: scene.min_gap,
        region: scene.region(frame)?,
    })
}

/// A progress bar on standard error counting `total` `unit`s (with rate and
/// time left), or none when `quiet` or when standard error is not a terminal.
pub fn progress_bar(quiet: bool, unit: &str, total: u64) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let template = format!("{{bar:40}} {{pos}}/{{len}} {unit}  {{per_sec}}  eta {{eta}}");
    let style = indicatif::ProgressStyle::with_template(&template).expect("valid template");
    let bar = indicatif::ProgressBar::new(total);
    bar.set_style(style);
    Some(bar)
}

/// The most worker threads `--threads` accepts: four per core, at most 256
/// (more only adds start-up time and memory; the results are the same).
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (4 * cores).min(256)
}

/// The worker pool for `--threads` (`None`: one thread per core). Zero and
/// more than [`max_threads`] are refused.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let max = max_threads();
    if let Some(n) = threads
        && (n == 0 || n > max)
    {
        return Err(crate::Error::usage(format!(
            "--threads must be between 1 and {max} (4 per core, at most 256) on this machine, got {n}"
        )));
    }
    let threads = threads.unwrap_or(0);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::usage(format!("cannot start {threads} worker threads: {e}")))
}

/// Where a command prints its summary: standard output, or standard error
/// when one of its outputs is `-` (the file itself goes to standard output).
pub fn summary_stream(outputs: &[&std::path::Path]) -> Box<dyn std::io::Write> {
    if outputs.iter().any(|p| crate::atomic::is_stdout(p)) {
        Box::new(std::io::stderr())
    } else {
        Box::new(std::io::stdout())
    }
}

/// Print a command's summary on its [`summary_stream`]: as one JSON object
/// with `--json`, else as the text `text` writes.
pub fn print_summary<T: serde::Serialize>(
    outputs: &[&std::path::Path],
    json: bool,
    summary: &T,
    text: impl FnOnce(&mut dyn std::io::Write),
) {
    let mut out = summary_stream(outputs);
    if json {
        let line = serde_json::to_string(summary).expect("summary serialises");
        let _ = writeln!(out, "{line}");
    } else {
        text(&mut out);
    }
}
