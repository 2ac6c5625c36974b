//! Arguments shared by several subcommands (input reading, scene preparation)
//! and the helpers that turn them into library parameters.

use std::path::PathBuf;

use clap::Args;

use crate::Result;
use crate::cells::{CellParams, DEFAULT_MARGIN, DEFAULT_MAX_CELL_EDGE, DEFAULT_MIN_GAP};
use crate::input::{DEFAULT_HEIGHT, Format, InputOptions};
use crate::prepare::{DEFAULT_EPS, PrepareParams};

/// How to read the city file.
#[derive(Args, Debug, Clone)]
pub struct InputArgs {
    /// GeoJSON coordinates are metres, used as they are, instead of lon/lat
    /// (OSM PBF is always lon/lat; CityJSON always metres).
    #[arg(long)]
    pub metric: bool,
    /// Height in metres for buildings with no height or level tags.
    #[arg(long, default_value_t = DEFAULT_HEIGHT, value_name = "METRES")]
    pub default_height: f64,
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
            default_height: self.default_height,
            strict: self.strict,
            format: self.format,
        }
    }
}

/// How to merge, shrink and cut the city into cells.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Erosion distance eps in metres; sample spacing and pixel size follow from it.
    #[arg(long, default_value_t = DEFAULT_EPS, value_name = "METRES")]
    pub eps: f64,
    /// Longest allowed view-cell edge in metres.
    #[arg(long, default_value_t = DEFAULT_MAX_CELL_EDGE, value_name = "METRES")]
    pub max_cell_edge: f64,
    /// Margin in metres added around the footprints' bounding box.
    #[arg(long, default_value_t = DEFAULT_MARGIN, value_name = "METRES")]
    pub margin: f64,
    /// Narrowest gap in metres a viewer can stand in: free space narrower
    /// than this gets no cells (occluders are unchanged); 0 keeps every gap.
    #[arg(long, default_value_t = DEFAULT_MIN_GAP, value_name = "METRES")]
    pub min_gap: f64,
    /// A GeoJSON polygon (in the city's frame) to use as region of interest.
    #[arg(long, value_name = "FILE")]
    pub region: Option<PathBuf>,
}

impl SceneArgs {
    /// Parameters for [`crate::prepare::prepare`]; reads the region file if any.
    pub fn params(&self, frame: &crate::input::Frame) -> Result<PrepareParams> {
        let region = match &self.region {
            Some(path) => Some(crate::input::read_region(path, frame)?),
            None => None,
        };
        if !(self.max_cell_edge > 0.0 && self.max_cell_edge.is_finite()) {
            return Err(crate::Error::new(format!(
                "--max-cell-edge must be a positive number of metres, got {}",
                self.max_cell_edge
            )));
        }
        if !(self.margin >= 0.0 && self.margin.is_finite()) {
            return Err(crate::Error::new(format!(
                "--margin must be zero or a positive number of metres, got {}",
                self.margin
            )));
        }
        if !(self.min_gap >= 0.0 && self.min_gap.is_finite()) {
            return Err(crate::Error::new(format!(
                "--min-gap must be zero or a positive number of metres, got {}",
                self.min_gap
            )));
        }
        Ok(PrepareParams {
            eps: self.eps,
            cells: CellParams {
                margin: self.margin,
                max_edge: self.max_cell_edge,
                region,
                min_gap: self.min_gap,
            },
        })
    }
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

/// The worker pool for `--threads` (`None`: one thread per core).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let threads = threads.unwrap_or(0);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| crate::Error::new(format!("cannot start {threads} worker threads: {e}")))
}
