//! `citypvs render`: read and prepare a city, pick a cell, gather its
//! visible set (from a `.pvs` file or computed here), its cull map and every
//! cell's PVS size as asked, and write the picture as a PNG.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};

use super::common::{InputArgs, SceneArgs};
use crate::input::read_city;
use crate::prepare::{Scene, prepare};
use crate::pvs::PvsReader;
use crate::render::{DEFAULT_SIZE, Focus, Picture, Rendered, cell_containing, render, view_around};
use crate::visibility::{DEFAULT_EYE_HEIGHT, VisibilityParams, cell_cull_map, compute_pvs};
use crate::{Error, Result};

/// Half-size in metres of the cull map drawn around the chosen cell when
/// no --radius is given.
pub const DEFAULT_CULL_MAP_RADIUS: f64 = 160.0;

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
    /// A .pvs file baked from the same city with the same scene options: the
    /// visible sets, eye height and pixel size are read from it. Without it
    /// the chosen cell's set (and with --layer pvs-size every cell's) is
    /// computed here with the bake's code.
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
    /// Eye height in metres when there is no --pvs (a .pvs file brings its own).
    #[arg(long, default_value_t = DEFAULT_EYE_HEIGHT, value_name = "METRES", conflicts_with = "pvs")]
    pub eye_height: f64,
    #[command(flatten)]
    pub input: InputArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
}

/// Parse "X,Y" into two finite numbers.
fn parse_point(text: &str) -> Result<(f64, f64)> {
    let bad = || {
        Error::new(format!(
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

/// Open the .pvs file and make sure it was baked from this scene.
fn open_pvs(path: &Path, scene: &Scene, args: &RenderArgs) -> Result<PvsReader> {
    let reader = PvsReader::open(path)?;
    let info = reader.info();
    if info.source_hash != scene.city.source_hash {
        return Err(Error::new(format!(
            "{} was baked from a different input than {} (the SHA-256 of the input differs)",
            path.display(),
            args.city.display()
        )));
    }
    let ids_match = reader
        .object_ids()
        .iter()
        .eq(scene.city.buildings.iter().map(|b| &b.id));
    if !ids_match
        || info.eps != scene.eps
        || reader.cell_triangles() != scene.cells.triangles.as_slice()
    {
        return Err(Error::new(format!(
            "{}: its {} cells and {} objects (eps {}) are not the {} cells and {} buildings (eps {}) \
             prepared here; it was baked with --eps {} --max-cell-edge {} --margin {}: pass the same scene options \
             (and the same --default-height, --region and --metric)",
            path.display(),
            reader.cell_count(),
            reader.object_ids().len(),
            info.eps,
            scene.cells.triangles.len(),
            scene.city.buildings.len(),
            scene.eps,
            info.eps,
            info.max_cell_edge,
            info.margin
        )));
    }
    Ok(reader)
}

fn chosen_cell(
    args: &RenderArgs,
    scene: &Scene,
    reader: Option<&PvsReader>,
) -> Result<Option<usize>> {
    if let Some(cell) = args.cell {
        let cells = scene.cells.triangles.len();
        if cell >= cells {
            return Err(Error::new(format!(
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
        Error::new(format!(
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
        return Err(Error::new(format!(
            "--radius must be a positive number of metres, got {r}"
        )));
    }
    let has_cell = args.cell.is_some() || args.at.is_some();
    if !has_cell && (args.layer.contains(&Layer::Cullmap) || args.radius.is_some()) {
        return Err(Error::new(
            "--layer cullmap and --radius need a chosen cell: add --cell N or --at X,Y".to_string(),
        ));
    }
    Ok(())
}

/// A drawn picture and the chosen cell it shows, if any.
pub struct Drawing {
    pub rendered: Rendered,
    pub focus: Option<Focus>,
}

/// Everything after preparation: open the .pvs file if any, choose the
/// cell, gather its visible set, cull map and the PVS sizes as asked, draw.
pub fn draw(args: &RenderArgs, scene: &Scene) -> Result<Drawing> {
    check_args(args)?;
    let reader = match &args.pvs {
        Some(path) => Some(open_pvs(path, scene, args)?),
        None => None,
    };
    let params = match &reader {
        Some(r) => VisibilityParams {
            eye_height: r.info().eye_height,
            pixel: r.info().pixel,
            ..VisibilityParams::for_eps(scene.eps)
        },
        None => VisibilityParams {
            eye_height: args.eye_height,
            ..VisibilityParams::for_eps(scene.eps)
        },
    };
    let cell = chosen_cell(args, scene, reader.as_ref())?;
    let wants = |layer| args.layer.contains(&layer);
    let focus = match (cell, &reader) {
        (Some(c), Some(r)) => Some(Focus::new(scene, &params, c, r.visible(c)?)?),
        (Some(c), None) => Some(Focus::compute(scene, &params, c)?),
        (None, _) => None,
    };
    let cull_map = match cell {
        Some(c) if wants(Layer::Cullmap) => Some(cell_cull_map(
            scene,
            &params,
            c,
            args.radius.unwrap_or(DEFAULT_CULL_MAP_RADIUS),
        )),
        _ => None,
    };
    let pvs_sizes: Option<Vec<usize>> = match &reader {
        _ if !wants(Layer::PvsSize) => None,
        Some(r) => Some(
            (0..r.cell_count())
                .map(|c| r.visible(c).map(|v| v.len()))
                .collect::<Result<_>>()?,
        ),
        None => {
            eprintln!(
                "computing the PVS of all {} cells (pass --pvs FILE to read them from a bake)",
                scene.cells.triangles.len()
            );
            let result = compute_pvs(scene, &params, &|_| {})?;
            Some(result.visible.iter().map(Vec::len).collect())
        }
    };
    let view = match (cell, args.radius) {
        (Some(c), Some(r)) => Some(view_around(scene, c, r)),
        _ => None,
    };
    let mut rendered = render(&Picture {
        scene,
        focus: focus.as_ref(),
        cull_map: cull_map.as_ref(),
        pvs_sizes: pvs_sizes.as_deref(),
        view,
        width: args.size,
    })?;
    if wants(Layer::Dropped) {
        rendered.overlay_dropped(scene);
    }
    Ok(Drawing { rendered, focus })
}

pub fn run(args: &RenderArgs) -> Result<i32> {
    check_args(args)?;
    let city = read_city(&args.city, &args.input.options())?;
    let prepare_params = args.scene.params(&city.frame)?;
    let scene = prepare(city, &prepare_params)?;
    let Drawing { rendered, focus } = draw(args, &scene)?;
    let png = rendered.png()?;
    crate::atomic::write_atomically(&args.output, &png)?;
    print!(
        "wrote {} ({} x {} px, {} KB)",
        args.output.display(),
        rendered.pixmap.width(),
        rendered.pixmap.height(),
        png.len().div_ceil(1024)
    );
    match &focus {
        Some(f) => println!(
            ": cell {}, {} of {} buildings visible",
            f.cell,
            f.visible.len(),
            scene.city.buildings.len()
        ),
        None => println!(),
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
