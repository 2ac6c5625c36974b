//! `citypvs prepare`: read a city, build blocks, occluders and cells, report.

use std::path::PathBuf;
use std::time::Instant;

use clap::Args;

use super::common::{CacheArgs, InputArgs, SceneArgs};
use crate::Result;
use crate::input::read_city;

#[derive(Args, Debug)]
pub struct PrepareArgs {
    /// The city file (GeoJSON, OSM PBF or CityJSON).
    pub city: PathBuf,
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub cache: CacheArgs,
    /// Write the view cells as GeoJSON in the input's frame.
    #[arg(long, value_name = "FILE")]
    pub export_cells: Option<PathBuf>,
    /// Write the shrunk occluders as GeoJSON in the input's frame.
    #[arg(long, value_name = "FILE")]
    pub export_occluders: Option<PathBuf>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &PrepareArgs) -> Result<i32> {
    let outputs: Vec<&std::path::Path> = args
        .export_cells
        .iter()
        .chain(args.export_occluders.iter())
        .map(PathBuf::as_path)
        .collect();
    let inputs: Vec<&std::path::Path> = std::iter::once(&args.city)
        .chain(args.scene.region.iter())
        .map(PathBuf::as_path)
        .collect();
    let t = Instant::now();
    let city = read_city(&args.city, &args.input.options())?;
    let read_seconds = t.elapsed().as_secs_f64();
    for output in &outputs {
        crate::atomic::check_output(output, &inputs)?;
    }
    let all: Vec<&std::path::Path> = inputs.iter().chain(&outputs).copied().collect();
    args.cache.check(&all)?;
    let settings = super::common::settings(&args.scene, None, &city.frame)?;
    let (scene, cache) = args
        .cache
        .prepare(city, read_seconds, &settings, &mut |line| {
            eprintln!("{line}")
        })?;
    if let Some(path) = &args.export_cells {
        crate::atomic::write_atomically(path, crate::prepare::cells_geojson(&scene).as_bytes())?;
    }
    if let Some(path) = &args.export_occluders {
        crate::atomic::write_atomically(
            path,
            crate::prepare::occluders_geojson(&scene).as_bytes(),
        )?;
    }
    let mut summary = crate::prepare::summary(&scene);
    summary.geometry_cache = cache;
    super::common::print_summary(&outputs, args.json, &summary, |out| {
        let _ = write!(out, "{}", summary.to_text());
    });
    Ok(0)
}
