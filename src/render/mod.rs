//! PNG pictures of a city, its cells, a cell's PVS and its cull map (tiny-skia).
//!
//! [`render`] draws a [`Picture`]: a prepared scene, optionally a chosen cell
//! with its visible set ([`Focus`]), its cull map and every cell's PVS size,
//! as a north-up map above a panel with the legend, a scale bar and a north
//! arrow. Nothing here reads files, so tests can draw hand-made scenes.
//!
//! Submodules: [`focus`] (the chosen cell), [`viewport`] (metres to pixels),
//! [`palette`] (colours), [`font`] (a built-in stroke font), `map` (the
//! map layers), `legend` (the panel).

mod encode;
pub mod focus;
pub mod font;
mod legend;
mod map;
pub mod palette;
mod request;
pub mod viewport;

use glam::DVec2;
use tiny_skia::{Pixmap, PixmapPaint, Transform};

use crate::model::{Rect, multipolygon_bounds};
use crate::prepare::Scene;
use crate::visibility::CullMapImage;
use crate::{Error, Result};
pub use focus::Focus;
use legend::{Entry, Mark};
use palette::Rgb;
pub use request::{DEFAULT_CULL_MAP_RADIUS, Drawing, Request, draw};
pub use viewport::Viewport;

/// Default picture width in pixels.
pub const DEFAULT_SIZE: u32 = 1600;
/// Narrowest picture width that keeps the legend legible.
pub const MIN_SIZE: u32 = 200;
/// Widest picture width accepted (a map up to twice as tall takes 0.5 GB).
pub const MAX_SIZE: u32 = 8_000;

/// Everything one picture shows.
#[derive(Clone, Copy, Debug)]
pub struct Picture<'a> {
    pub scene: &'a Scene,
    /// A chosen cell: filled, its visible and culled buildings coloured
    /// apart, its sample points drawn.
    pub focus: Option<&'a Focus>,
    /// The chosen cell's cull map, drawn as a heat map of shadow heights
    /// under the buildings, with the shrunk occluders outlined.
    pub cull_map: Option<&'a CullMapImage>,
    /// Every cell's PVS size (one per cell), drawn as a heat map of cells.
    pub pvs_sizes: Option<&'a [usize]>,
    /// The rectangle of local metres to show; `None` shows the whole scene.
    pub view: Option<Rect>,
    /// Picture width in pixels; the height follows the view's shape.
    pub width: u32,
}

/// A drawn picture and where its map lies in it.
pub struct Rendered {
    pub pixmap: Pixmap,
    /// The map occupies rows `0..viewport.height`; the panel is below.
    pub viewport: Viewport,
    /// Colours the PNG must keep exactly: the flat colours and the steps of
    /// the ramps shown.
    exact_colours: Vec<Rgb>,
}

impl Rendered {
    /// The colour of the picture pixel holding a point (local metres), if
    /// the point is on the map.
    pub fn colour_at(&self, p: DVec2) -> Option<Rgb> {
        let (x, y) = self.viewport.pixel_of(p)?;
        let c = self.pixmap.pixel(x, y)?.demultiply();
        Some(Rgb(c.red(), c.green(), c.blue()))
    }

    /// The picture as PNG bytes: an 8-bit palette image. The flat colours
    /// and ramp steps are kept exactly; with more than 256 colours in all,
    /// anti-aliased blends take the nearest palette entry.
    pub fn png(&self) -> Result<Vec<u8>> {
        encode::encode_png(&self.pixmap, &self.exact_colours)
    }
}

impl Rendered {
    /// Draw the free space dropped as too narrow (`scene.cells.dropped`) in
    /// red over the map.
    pub fn overlay_dropped(&mut self, scene: &Scene) {
        let line = map::hairline(self.pixmap.width());
        // Drawn on a map-sized layer so nothing spills into the panel.
        let Some(mut layer) = Pixmap::new(self.viewport.width, self.viewport.height) else {
            return;
        };
        map::fill_polygons(
            &mut layer,
            &self.viewport,
            &scene.cells.dropped,
            palette::DROPPED,
            line,
        );
        self.pixmap.draw_pixmap(
            0,
            0,
            layer.as_ref(),
            &PixmapPaint::default(),
            Transform::identity(),
            None,
        );
        self.exact_colours.push(palette::DROPPED);
    }
}

/// The bounding rectangle of a scene: its cells, its region and its buildings.
pub fn scene_bounds(scene: &Scene) -> Rect {
    let cells = Rect::of_points(scene.cells.triangles.iter().flatten());
    let region = Rect::of_points(scene.cells.region.exterior.iter());
    scene
        .city
        .buildings
        .iter()
        .map(|b| multipolygon_bounds(&b.footprint))
        .fold(cells.union(&region), |r, b| r.union(&b))
}

/// The square of half-size `radius` metres around the centre of `cell`.
/// Panics if `cell` is not a cell of the scene.
pub fn view_around(scene: &Scene, cell: usize, radius: f64) -> Rect {
    let t = scene.cells.triangles[cell];
    let centre = (t[0] + t[1] + t[2]) / 3.0;
    Rect {
        min: centre - DVec2::splat(radius),
        max: centre + DVec2::splat(radius),
    }
}

/// The lowest-numbered cell containing a point (local metres), if any: the
/// lookup a `.pvs` reader answers (`PvsReader::cell_at`), over the scene's cells.
pub fn cell_containing(scene: &Scene, p: DVec2) -> Option<usize> {
    let cells = &scene.cells.triangles;
    crate::pvs::CellGrid::new(cells.len(), |c| cells[c]).find(p, 0.0, |c| cells[c])
}

fn check(picture: &Picture) -> Result<Rect> {
    let scene = picture.scene;
    if !(MIN_SIZE..=MAX_SIZE).contains(&picture.width) {
        return Err(Error::usage(format!(
            "--size must be between {MIN_SIZE} and {MAX_SIZE} pixels, got {}",
            picture.width
        )));
    }
    if let Some(f) = picture.focus
        && f.cell >= scene.cells.triangles.len()
    {
        return Err(Error::usage(format!(
            "cell {} does not exist (the scene has {} cells)",
            f.cell,
            scene.cells.triangles.len()
        )));
    }
    if let Some(sizes) = picture.pvs_sizes
        && sizes.len() != scene.cells.triangles.len()
    {
        return Err(Error::usage(format!(
            "{} PVS sizes given for {} cells",
            sizes.len(),
            scene.cells.triangles.len()
        )));
    }
    if let Some(c) = picture.cull_map
        && (c.heights.len() != c.width * c.height || c.pixel.is_nan() || c.pixel <= 0.0)
    {
        return Err(Error::usage(format!(
            "the cull map's {} heights do not fill {} x {} pixels of {} m",
            c.heights.len(),
            c.width,
            c.height,
            c.pixel
        )));
    }
    let view = picture.view.unwrap_or_else(|| scene_bounds(scene));
    let finite = [view.min, view.max].iter().all(|p| p.is_finite());
    if !finite || view.is_empty() || view.width() <= 0.0 && view.height() <= 0.0 {
        return Err(Error::usage(
            "nothing to draw: the scene has no cells and no buildings".to_string(),
        ));
    }
    Ok(view)
}

/// Tallest building in the scene (at least 1 m, so ramps have a range).
fn tallest(scene: &Scene) -> f64 {
    scene
        .city
        .buildings
        .iter()
        .map(|b| b.height)
        .fold(1.0, f64::max)
}

fn metres(v: f64) -> String {
    if v == v.round() {
        format!("{v:.0} M")
    } else if v < 10.0 {
        format!("{v:.1} M")
    } else {
        format!("{v:.0} M")
    }
}

/// The legend entries for what the picture shows.
fn legend_entries(
    picture: &Picture,
    sizes: Option<(usize, usize)>,
    max_height: f64,
    cell_outlines: bool,
) -> Vec<Entry> {
    let scene = picture.scene;
    let mut entries = Vec::new();
    let swatch = |colour, mark, label: &str| Entry::Swatch {
        colour,
        mark,
        label: label.to_string(),
    };
    match picture.focus {
        Some(f) => {
            let n = scene.city.buildings.len();
            entries.push(Entry::Text(format!(
                "CELL {}: {} OF {} BUILDINGS VISIBLE",
                f.cell,
                f.visible.len(),
                n
            )));
            entries.push(swatch(palette::CHOSEN_CELL, Mark::Fill, "CHOSEN CELL"));
            entries.push(swatch(palette::SAMPLE, Mark::Dot, "SAMPLE POINT"));
            entries.push(swatch(palette::VISIBLE, Mark::Fill, "VISIBLE"));
            entries.push(swatch(palette::CULLED, Mark::Fill, "CULLED"));
        }
        None if picture.pvs_sizes.is_some() => {
            entries.push(swatch(palette::NEUTRAL_BUILDING, Mark::Fill, "BUILDING"));
        }
        None => entries.push(Entry::Ramp {
            ramp: palette::HEIGHT_RAMP,
            label: "BUILDING HEIGHT".into(),
            low: metres(0.0),
            high: metres(max_height),
        }),
    }
    if cell_outlines {
        entries.push(swatch(palette::CELL_OUTLINE, Mark::Outline, "VIEW CELL"));
    }
    if let Some((lo, hi)) = sizes {
        entries.push(Entry::Ramp {
            ramp: palette::PVS_RAMP,
            label: "PVS SIZE (BUILDINGS)".into(),
            low: lo.to_string(),
            high: hi.to_string(),
        });
    }
    if picture.cull_map.is_some() {
        entries.push(Entry::Ramp {
            ramp: palette::CULL_RAMP,
            label: "CULL MAP: HIDES BELOW".into(),
            low: metres(0.0),
            high: metres(max_height),
        });
        entries.push(swatch(
            palette::OCCLUDER_OUTLINE,
            Mark::Outline,
            "SHRUNK OCCLUDER",
        ));
    }
    entries
}

/// The ramps a legend shows.
fn legend_ramps(entries: &[Entry]) -> impl Iterator<Item = palette::Ramp> + '_ {
    entries.iter().filter_map(|e| match e {
        Entry::Ramp { ramp, .. } => Some(*ramp),
        _ => None,
    })
}

/// Draw a picture.
pub fn render(picture: &Picture) -> Result<Rendered> {
    let view = check(picture)?;
    let scene = picture.scene;
    let width = picture.width;
    let vp = Viewport::fit(view, width);
    let line = map::hairline(width);
    let max_height = tallest(scene);
    let size_range = picture.pvs_sizes.map(|s| {
        let lo = s.iter().copied().min().unwrap_or(0);
        let hi = s.iter().copied().max().unwrap_or(0);
        (lo, hi)
    });

    let mut map = Pixmap::new(vp.width, vp.height).ok_or_else(|| {
        Error::usage(format!(
            "cannot make a {} x {} picture",
            vp.width, vp.height
        ))
    })?;
    map::fill_outside(&mut map);
    let triangles = &scene.cells.triangles;
    match (picture.pvs_sizes, size_range) {
        (Some(sizes), Some((lo, hi))) => {
            let span = (hi - lo).max(1) as f64;
            map::fill_cells(&mut map, &vp, triangles, |c| {
                palette::PVS_RAMP.step((sizes[c] - lo) as f64 / span)
            })
        }
        _ => map::fill_cells(&mut map, &vp, triangles, |_| palette::FREE_SPACE),
    }
    if let Some(image) = picture.cull_map {
        map::draw_cull_map(&mut map, &vp, image, max_height, palette::CULL_RAMP, line);
    }
    // Over the PVS-size heat map the cells show as patches of colour;
    // outlines would only blur it (and double the PNG).
    let outline_alpha = match picture.pvs_sizes {
        Some(_) => 0.0,
        None => map::cell_outline_alpha(&vp, triangles),
    };
    map::outline_cells(&mut map, &vp, triangles, line, outline_alpha);
    if let Some(f) = picture.focus {
        map::draw_chosen_cell(&mut map, &vp, &triangles[f.cell], 1.5 * line);
    }
    let buildings = &scene.city.buildings;
    let colour_of = |b: usize| match picture.focus {
        Some(f) if f.sees(b) => palette::VISIBLE,
        Some(_) => palette::CULLED,
        None if picture.pvs_sizes.is_some() => palette::NEUTRAL_BUILDING,
        None => palette::HEIGHT_RAMP.step(buildings[b].height / max_height),
    };
    map::draw_buildings(&mut map, &vp, buildings, colour_of, line);
    if picture.cull_map.is_some() {
        let shapes = scene.occluders.iter().map(|o| o.shape.as_slice());
        map::outline_occluders(&mut map, &vp, shapes, 1.2 * line);
    }
    if let Some(f) = picture.focus {
        map::draw_samples(&mut map, &vp, &f.samples, (2.5 * line).max(1.5));
    }

    let entries = legend_entries(picture, size_range, max_height, outline_alpha > 0.0);
    let layout = legend::layout(&entries, width, vp.scale);
    let total = vp.height + layout.height();
    let mut pixmap = Pixmap::new(width, total)
        .ok_or_else(|| Error::usage(format!("cannot make a {width} x {total} picture")))?;
    pixmap.fill(palette::PANEL.color());
    pixmap.draw_pixmap(
        0,
        0,
        map.as_ref(),
        &PixmapPaint::default(),
        Transform::identity(),
        None,
    );
    legend::draw(&mut pixmap, &entries, &layout, vp.height as f32, vp.scale);
    let mut exact_colours = palette::FLAT.to_vec();
    for ramp in legend_ramps(&entries) {
        exact_colours.extend(ramp.steps());
    }
    Ok(Rendered {
        pixmap,
        viewport: vp,
        exact_colours,
    })
}
