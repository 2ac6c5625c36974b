//! The map layers, each drawn onto the map pixmap through the viewport:
//! free space and view cells, the cull-map heat, buildings, shrunk occluder
//! outlines, the chosen cell and its sample points.

use glam::DVec2;
use tiny_skia::{
    FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, PremultipliedColorU8, Rect as SkRect,
    Stroke, StrokeDash, Transform,
};

use super::palette::{self, Ramp, Rgb};
use super::viewport::Viewport;
use crate::model::{Building, Polygon, Rect, multipolygon_bounds};
use crate::visibility::CullMapImage;

fn paint(colour: Rgb, alpha: f32, anti_alias: bool) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(colour.with_alpha(alpha));
    p.anti_alias = anti_alias;
    p
}

fn stroke(width: f32) -> Stroke {
    Stroke {
        width,
        line_cap: LineCap::Round,
        line_join: LineJoin::Round,
        ..Stroke::default()
    }
}

/// Append a closed ring (local metres) to a path in picture pixels.
fn add_ring(pb: &mut PathBuilder, vp: &Viewport, ring: &[DVec2]) {
    for (k, p) in ring.iter().enumerate() {
        let (x, y) = vp.to_screen(*p);
        if k == 0 {
            pb.move_to(x, y);
        } else {
            pb.line_to(x, y);
        }
    }
    if !ring.is_empty() {
        pb.close();
    }
}

fn add_polygon(pb: &mut PathBuilder, vp: &Viewport, polygon: &Polygon) {
    add_ring(pb, vp, &polygon.exterior);
    for hole in &polygon.holes {
        add_ring(pb, vp, hole);
    }
}

/// A line width in pixels that stays visible at any scale.
pub fn hairline(picture_width: u32) -> f32 {
    (picture_width as f32 / 1600.0).max(0.6)
}

/// Fill the whole map with the colour of space outside every cell.
pub fn fill_outside(map: &mut Pixmap) {
    map.fill(palette::OUTSIDE.color());
}

/// Fill every cell that reaches into the view with `colour_of(cell)`. No
/// anti-aliasing, so neighbouring cells leave no seams.
pub fn fill_cells(
    map: &mut Pixmap,
    vp: &Viewport,
    triangles: &[[DVec2; 3]],
    colour_of: impl Fn(usize) -> Rgb,
) {
    for (c, t) in triangles.iter().enumerate() {
        if !Rect::of_points(t.iter()).intersects(&vp.view) {
            continue;
        }
        let mut pb = PathBuilder::new();
        add_ring(&mut pb, vp, t);
        if let Some(path) = pb.finish() {
            map.fill_path(
                &path,
                &paint(colour_of(c), 1.0, false),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    }
}

/// Opacity of the cell outlines: they fade out as cells shrink on screen
/// (median edge from 25 px down to 6 px), so a whole city's thousands of
/// cells do not bury the map in grey.
pub fn cell_outline_alpha(vp: &Viewport, triangles: &[[DVec2; 3]]) -> f32 {
    let mut edges: Vec<f64> = triangles
        .iter()
        .filter(|t| Rect::of_points(t.iter()).intersects(&vp.view))
        .flat_map(|t| (0..3).map(move |k| t[k].distance(t[(k + 1) % 3])))
        .collect();
    if edges.is_empty() {
        return 0.0;
    }
    edges.sort_by(f64::total_cmp);
    let median_px = edges[edges.len() / 2] * vp.scale;
    (((median_px - 6.0) / 24.0) as f32).clamp(0.0, 0.8)
}

/// Thin outlines of every cell in the view at opacity `alpha`, stroked as
/// one path so shared edges are not darkened twice. Not anti-aliased: the
/// hairlines look the same and the PNG is half the size.
pub fn outline_cells(
    map: &mut Pixmap,
    vp: &Viewport,
    triangles: &[[DVec2; 3]],
    width: f32,
    alpha: f32,
) {
    if alpha <= 0.0 {
        return;
    }
    let mut pb = PathBuilder::new();
    for t in triangles {
        if Rect::of_points(t.iter()).intersects(&vp.view) {
            add_ring(&mut pb, vp, t);
        }
    }
    if let Some(path) = pb.finish() {
        map.stroke_path(
            &path,
            &paint(palette::CELL_OUTLINE, alpha, false),
            &stroke(width),
            Transform::identity(),
            None,
        );
    }
}

/// Colour every map pixel whose centre falls on a cull-map pixel with a
/// shadow above the ground: `ramp` from 0 to `max_height` metres (higher
/// shadows get the ramp's end). Then a dashed line around the cull map.
pub fn draw_cull_map(
    map: &mut Pixmap,
    vp: &Viewport,
    image: &CullMapImage,
    max_height: f64,
    ramp: Ramp,
    line_width: f32,
) {
    let extent = Rect {
        min: image.origin,
        max: image.origin + DVec2::new(image.width as f64, image.height as f64) * image.pixel,
    };
    let (x0, y0) = vp.to_screen(DVec2::new(extent.min.x, extent.max.y));
    let (x1, y1) = vp.to_screen(DVec2::new(extent.max.x, extent.min.y));
    let clamp_to = |v: f32, n: u32| (v.max(0.0) as u32).min(n);
    let (xa, xb) = (
        clamp_to(x0.floor(), vp.width),
        clamp_to(x1.ceil(), vp.width),
    );
    let (ya, yb) = (
        clamp_to(y0.floor(), vp.height),
        clamp_to(y1.ceil(), vp.height),
    );
    let width = map.width() as usize;
    let pixels = map.pixels_mut();
    for y in ya..yb {
        for x in xa..xb {
            let p = vp.to_world(x, y);
            let i = ((p.x - image.origin.x) / image.pixel).floor();
            let j = ((p.y - image.origin.y) / image.pixel).floor();
            if i < 0.0 || j < 0.0 || i >= image.width as f64 || j >= image.height as f64 {
                continue;
            }
            let h = image.heights[j as usize * image.width + i as usize] as f64;
            if h > 0.0 {
                let t = if max_height > 0.0 {
                    h / max_height
                } else {
                    1.0
                };
                let c = ramp.step(t);
                pixels[y as usize * width + x as usize] =
                    PremultipliedColorU8::from_rgba(c.0, c.1, c.2, 255).expect("opaque colour");
            }
        }
    }
    if let Some(rect) = SkRect::from_ltrb(x0, y0, x1, y1) {
        let path = PathBuilder::from_rect(rect);
        let mut s = stroke(line_width);
        s.dash = StrokeDash::new(vec![6.0 * line_width, 4.0 * line_width], 0.0);
        map.stroke_path(
            &path,
            &paint(palette::INK, 0.8, true),
            &s,
            Transform::identity(),
            None,
        );
    }
}

/// Fill the chosen cell and outline it; when it is small on screen, also
/// ring it so it can be found on a whole-city map.
pub fn draw_chosen_cell(map: &mut Pixmap, vp: &Viewport, triangle: &[DVec2; 3], line_width: f32) {
    let mut pb = PathBuilder::new();
    add_ring(&mut pb, vp, triangle);
    if let Some(path) = pb.finish() {
        map.fill_path(
            &path,
            &paint(palette::CHOSEN_CELL, 1.0, true),
            FillRule::Winding,
            Transform::identity(),
            None,
        );
        map.stroke_path(
            &path,
            &paint(palette::INK, 1.0, true),
            &stroke(line_width),
            Transform::identity(),
            None,
        );
    }
    let ring_radius = 12.0 * line_width;
    let size = Rect::of_points(triangle.iter());
    if (size.width().max(size.height()) * vp.scale) < ring_radius as f64 {
        let (x, y) = vp.to_screen((triangle[0] + triangle[1] + triangle[2]) / 3.0);
        if let Some(circle) = PathBuilder::from_circle(x, y, ring_radius) {
            map.stroke_path(
                &circle,
                &paint(palette::CHOSEN_CELL, 1.0, true),
                &stroke(2.5 * line_width),
                Transform::identity(),
                None,
            );
        }
    }
}

/// Fill every building in the view with `colour_of(index)` and outline them all.
pub fn draw_buildings(
    map: &mut Pixmap,
    vp: &Viewport,
    buildings: &[Building],
    colour_of: impl Fn(usize) -> Rgb,
    line_width: f32,
) {
    let mut outlines = PathBuilder::new();
    for (b, building) in buildings.iter().enumerate() {
        if !multipolygon_bounds(&building.footprint).intersects(&vp.view) {
            continue;
        }
        let mut pb = PathBuilder::new();
        for polygon in &building.footprint {
            add_polygon(&mut pb, vp, polygon);
            add_polygon(&mut outlines, vp, polygon);
        }
        if let Some(path) = pb.finish() {
            map.fill_path(
                &path,
                &paint(colour_of(b), 1.0, true),
                FillRule::EvenOdd,
                Transform::identity(),
                None,
            );
        }
    }
    if let Some(path) = outlines.finish() {
        map.stroke_path(
            &path,
            &paint(palette::BUILDING_OUTLINE, 0.9, true),
            &stroke(line_width),
            Transform::identity(),
            None,
        );
    }
}

/// Outline the shrunk occluders that reach into the view.
pub fn outline_occluders<'a>(
    map: &mut Pixmap,
    vp: &Viewport,
    shapes: impl Iterator<Item = &'a [Polygon]>,
    line_width: f32,
) {
    let mut pb = PathBuilder::new();
    for shape in shapes {
        if multipolygon_bounds(shape).intersects(&vp.view) {
            for polygon in shape {
                add_polygon(&mut pb, vp, polygon);
            }
        }
    }
    if let Some(path) = pb.finish() {
        map.stroke_path(
            &path,
            &paint(palette::OCCLUDER_OUTLINE, 1.0, true),
            &stroke(line_width),
            Transform::identity(),
            None,
        );
    }
}

/// A dot with a white rim at every sample point.
pub fn draw_samples(map: &mut Pixmap, vp: &Viewport, samples: &[DVec2], radius: f32) {
    let mut pb = PathBuilder::new();
    for s in samples {
        let (x, y) = vp.to_screen(*s);
        pb.push_circle(x, y, radius);
    }
    if let Some(path) = pb.finish() {
        map.stroke_path(
            &path,
            &paint(palette::WHITE, 1.0, true),
            &stroke(radius * 0.8),
            Transform::identity(),
            None,
        );
        map.fill_path(
            &path,
            &paint(palette::SAMPLE, 1.0, true),
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
}

/// Fill polygons in one flat colour, outlined with a hairline of the same
/// colour so that parts thinner than a pixel still show.
pub fn fill_polygons(
    map: &mut Pixmap,
    vp: &Viewport,
    polygons: &[Polygon],
    colour: Rgb,
    line_width: f32,
) {
    let mut pb = PathBuilder::new();
    for polygon in polygons {
        if multipolygon_bounds(std::slice::from_ref(polygon)).intersects(&vp.view) {
            add_polygon(&mut pb, vp, polygon);
        }
    }
    if let Some(path) = pb.finish() {
        map.fill_path(
            &path,
            &paint(colour, 1.0, true),
            FillRule::EvenOdd,
            Transform::identity(),
            None,
        );
        map.stroke_path(
            &path,
            &paint(colour, 1.0, true),
            &stroke(line_width),
            Transform::identity(),
            None,
        );
    }
}
