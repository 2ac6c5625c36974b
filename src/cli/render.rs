//! `citypvs render`: read and prepare a city, pick a cell, gather its
//! visible set (from a `.pvs` file or computed here), its cull map and every
//! cell's PVS size as asked, and write the picture as a PNG.

use std::io::Write;
use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use super::common::{InputArgs, SceneArgs, ViewArgs};
use crate::input::read_city;
use crate::prepare::{Scene, prepare};
use crate::pvs::PvsReader;
use crate::render::{DEFAULT_SIZE, Drawing, Request, cell_containing};
use crate::{Error, Result};

/// Extra picture layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Layer {
    /// The chosen cell's cull map (shadow heights) under the buildings, and the shrunk occluders' outlines.
    Cullmap,
    /// Every cell coloured by the number of buildings it may see.
    PvsSize,
    /// The free space dropped as narrower than --min-gap, in red.
    Dropped,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The city file (GeoJSON, OSM PBF or CityJSON).
    pub city: PathBuf,
    /// Output PNG file.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// A .pvs file baked from the same city: the settings it was baked with
    /// (eps, cell edge, margin, eye height, pixel) and the visible sets are
    /// read from it, so scene and view flags cannot be given with it (only
    /// --region, which must be the bake's). Without it the chosen cell's set
    /// (and with --layer pvs-size every cell's) is computed here with the
    /// bake's code.
    #[arg(long, value_name = "FILE")]
    pub pvs: Option<PathBuf>,
    /// Show this cell (numbered from 0, as in `inspect`) and what it sees.
    #[arg(long, value_name = "N", conflicts_with = "at")]
    pub cell: Option<usize>,
    /// Show the cell containing this point, given in the input's coordinates:
    /// lon,lat in degrees for lon/lat input, metres with --metric. Write
    /// negative values as --at=-12.5,40.
    #[arg(long, value_name = "X,Y", allow_hyphen_values = true)]
    pub at: Option<String>,
    /// Extra layers, repeated or comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "LAYER")]
    pub layer: Vec<Layer>,
    /// Picture width in pixels; the height follows the map's shape.
    #[arg(long, default_value_t = DEFAULT_SIZE, value_name = "PIXELS")]
    pub size: u32,
    /// Show only the square of this half-size in metres around the chosen
    /// cell, and draw its cull map that far [default: the whole city, and a
    /// 160 m cull map].
    #[arg(long, value_name = "METRES")]
    pub radius: Option<f64>,
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub view: ViewArgs,
}

/// Parse "X,Y" into two finite numbers.
fn parse_point(text: &str) -> Result<(f64, f64)> {
    let bad = || {
        Error::usage(format!(
            "--at must be two numbers X,Y (e.g. --at=26.94,60.47), got \"{text}\""
        ))
    };
    let (x, y) = text.split_once(',').ok_or_else(bad)?;
    let x: f64 = x.trim().parse().map_err(|_| bad())?;
    let y: f64 = y.trim().parse().map_err(|_| bad())?;
    if !(x.is_finite() && y.is_finite()) {
        return Err(bad());
    }
    Ok((x, y))
}

/// Check that the .pvs file was baked from this scene (prepared with the
/// file's own settings).
fn check_pvs(path: &Path, reader: &PvsReader, scene: &Scene, args: &RenderArgs) -> Result<()> {
    let info = reader.info();
    if info.source_hash != scene.city.source_hash {
        return Err(Error::mismatch(format!(
            "{} was baked from a different input than {} (the SHA-256 of the input differs)",
            path.display(),
            args.city.display()
        )));
    }
    let baked = info.settings(scene.settings.region.clone())?;
    if baked != scene.settings {
        return Err(Error::mismatch(format!(
            "{} was baked with eps {}, max cell edge {}, margin {}, eye height {}, pixel {}, but the scene was \
             prepared with eps {}, max cell edge {}, margin {}, eye height {}, pixel {}",
            path.display(),
            baked.eps,
            baked.max_cell_edge,
            baked.margin,
            baked.eye_height,
            baked.pixel,
            scene.settings.eps,
            scene.settings.max_cell_edge,
            scene.settings.margin,
            scene.settings.eye_height,
            scene.settings.pixel
        )));
    }
    let ids_match = reader
        .object_ids()
        .iter()
        .eq(scene.city.buildings.iter().map(|b| &b.id));
    if !ids_match || reader.cell_triangles() != scene.cells.triangles.as_slice() {
        return Err(Error::mismatch(format!(
            "{}: its {} cells and {} objects are not the {} cells and {} buildings prepared here with its \
             settings: pass the same --default-height, --region and --metric as the bake",
            path.display(),
            reader.cell_count(),
            reader.object_ids().len(),
            scene.cells.triangles.len(),
            scene.city.buildings.len(),
        )));
    }
    Ok(())
}

fn chosen_cell(
    args: &RenderArgs,
    scene: &Scene,
    reader: Option<&PvsReader>,
) -> Result<Option<usize>> {
    if let Some(cell) = args.cell {
        let cells = scene.cells.triangles.len();
        if cell >= cells {
            return Err(Error::usage(format!(
                "--cell {cell} does not exist: {} has {cells} cells, numbered from 0",
                args.city.display()
            )));
        }
        return Ok(Some(cell));
    }
    let Some(text) = &args.at else {
        return Ok(None);
    };
    let (x, y) = parse_point(text)?;
    let local = scene.city.frame.to_local(x, y);
    let found = match reader {
        Some(r) => r.cell_at(local),
        None => cell_containing(scene, local),
    };
    found.map(Some).ok_or_else(|| {
        Error::usage(format!(
            "--at {x},{y} (local {:.1} m east, {:.1} m north) is in no view cell: it is inside a \
             building or outside the region",
            local.x, local.y
        ))
    })
}

/// Refuse option combinations that cannot work, before reading anything.
fn check_args(args: &RenderArgs) -> Result<()> {
    if let Some(r) = args.radius
        && !(r > 0.0 && r.is_finite())
    {
        return Err(Error::usage(format!(
            "--radius must be a positive number of metres, got {r}"
        )));
    }
    let has_cell = args.cell.is_some() || args.at.is_some();
    if !has_cell && (args.layer.contains(&Layer::Cullmap) || args.radius.is_some()) {
        return Err(Error::usage(
            "--layer cullmap and --radius need a chosen cell: add --cell N or --at X,Y".to_string(),
        ));
    }
    Ok(())
}

/// Check the arguments and the .pvs file, choose the cell, and hand the
/// request to [`crate::render::draw`].
pub fn draw(args: &RenderArgs, scene: &Scene, reader: Option<&PvsReader>) -> Result<Drawing> {
    check_args(args)?;
    if let (Some(path), Some(r)) = (&args.pvs, reader) {
        check_pvs(path, r, scene, args)?;
    }
    let cell = chosen_cell(args, scene, reader)?;
    if reader.is_none() && args.layer.contains(&Layer::PvsSize) {
        eprintln!(
            "computing the PVS of all {} cells (pass --pvs FILE to read them from a bake)",
            scene.cells.triangles.len()
        );
    }
    let mut drawing = crate::render::draw(
        scene,
        reader,
        &Request {
            cell,
            cull_map: args.layer.contains(&Layer::Cullmap),
            pvs_size: args.layer.contains(&Layer::PvsSize),
            radius: args.radius,
            width: args.size,
        },
    )?;
    if args.layer.contains(&Layer::Dropped) {
        drawing.rendered.overlay_dropped(scene);
    }
    Ok(drawing)
}

pub fn run(args: &RenderArgs) -> Result<i32> {
    check_args(args)?;
    let inputs: Vec<&Path> = std::iter::once(&args.city)
        .chain(args.pvs.iter())
        .chain(args.scene.region.iter())
        .map(PathBuf::as_path)
        .collect();
    crate::atomic::check_output(&args.output, &inputs)?;
    let reader = match &args.pvs {
        Some(path) => {
            let given: Vec<&str> = args
                .scene
                .given()
                .into_iter()
                .chain(args.view.given())
                .collect();
            if !given.is_empty() {
                return Err(Error::usage(format!(
                    "{} cannot be given with --pvs: the file's header holds the settings it was baked with",
                    given.join(", ")
                )));
            }
            Some(PvsReader::open(path)?)
        }
        None => None,
    };
    let city = read_city(&args.city, &args.input.options())?;
    let region = args.scene.region(&city.frame)?;
    let settings = match &reader {
        Some(r) => r.info().settings(region).map_err(|e| {
            e.context(
                args.pvs
                    .as_ref()
                    .expect("a reader comes from --pvs")
                    .display(),
            )
        })?,
        None => super::common::settings(&args.scene, Some(&args.view), &city.frame)?,
    };
    let scene = prepare(city, &settings)?;
    let Drawing { rendered, focus } = draw(args, &scene, reader.as_ref())?;
    let png = rendered.png()?;
    crate::atomic::write_atomically(&args.output, &png)?;
    let mut out = super::common::summary_stream(&[&args.output]);
    let _ = write!(
        out,
        "wrote {} ({} x {} px, {} KB)",
        args.output.display(),
        rendered.pixmap.width(),
        rendered.pixmap.height(),
        png.len().div_ceil(1024)
    );
    match &focus {
        Some(f) => say!(
            out,
            ": cell {}, {} of {} buildings visible",
            f.cell,
            f.visible.len(),
            scene.city.buildings.len()
        ),
        None => say!(out, ""),
    }
    Ok(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_parse_or_say_what_is_wrong() {
        assert_eq!(parse_point("26.94,60.47").unwrap(), (26.94, 60.47));
        assert_eq!(parse_point("-12.5, 40").unwrap(), (-12.5, 40.0));
        for bad in ["", "1", "1,x", "1;2", "nan,1", "1,2,3"] {
            let e = parse_point(bad).unwrap_err().to_string();
            assert!(e.contains("--at"), "{bad}: {e}");
        }
    }
}
