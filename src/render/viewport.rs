//! Where the map goes in the picture: the shown rectangle of local metres,
//! the pixels per metre, and the mapping from metres (y north) to pixels
//! (y down).

use glam::DVec2;

use crate::model::Rect;

/// The map's place in the picture: `view` (local metres) fills the pixels
/// `0..width` x `0..height` with north up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewport {
    /// The shown rectangle in local metres.
    pub view: Rect,
    /// Pixels per metre.
    pub scale: f64,
    /// Map width in pixels.
    pub width: u32,
    /// Map height in pixels.
    pub height: u32,
}

/// The map is at most this many times taller than wide (and at least the
/// inverse): a thinner view is widened so the picture stays readable.
const MAX_ASPECT: f64 = 2.0;

impl Viewport {
    /// Fit `view` into a map `width` pixels wide, north up, the height
    /// following the view's shape. Views thinner than 1 : 2 either way are
    /// grown around their centre. `view` must be non-empty with a positive
    /// area.
    pub fn fit(view: Rect, width: u32) -> Viewport {
        let centre = (view.min + view.max) * 0.5;
        let mut half = DVec2::new(view.width(), view.height()) * 0.5;
        half.x = half.x.max(half.y / MAX_ASPECT);
        half.y = half.y.max(half.x / MAX_ASPECT);
        let scale = width as f64 / (2.0 * half.x);
        let height = (2.0 * half.y * scale).round().max(1.0) as u32;
        // Grow the view to the whole pixel rows so the scale is the same both ways.
        half.y = height as f64 / scale * 0.5;
        Viewport {
            view: Rect {
                min: centre - half,
                max: centre + half,
            },
            scale,
            width,
            height,
        }
    }

    /// Picture coordinates (pixels, y down, continuous) of a point in local metres.
    pub fn to_screen(&self, p: DVec2) -> (f32, f32) {
        (
            ((p.x - self.view.min.x) * self.scale) as f32,
            ((self.view.max.y - p.y) * self.scale) as f32,
        )
    }

    /// The local metres at the centre of picture pixel (`x`, `y`).
    pub fn to_world(&self, x: u32, y: u32) -> DVec2 {
        DVec2::new(
            self.view.min.x + (x as f64 + 0.5) / self.scale,
            self.view.max.y - (y as f64 + 0.5) / self.scale,
        )
    }

    /// The picture pixel holding a point, if it is on the map.
    pub fn pixel_of(&self, p: DVec2) -> Option<(u32, u32)> {
        let (x, y) = self.to_screen(p);
        let (x, y) = (x.floor(), y.floor());
        if x < 0.0 || y < 0.0 || x >= self.width as f32 || y >= self.height as f32 {
            return None;
        }
        Some((x as u32, y as u32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_map_to_the_picture_corners_with_north_up() {
        let view = Rect {
            min: DVec2::new(-100.0, 0.0),
            max: DVec2::new(100.0, 100.0),
        };
        let v = Viewport::fit(view, 400);
        assert_eq!((v.width, v.height), (400, 200));
        assert_eq!(v.to_screen(DVec2::new(-100.0, 100.0)), (0.0, 0.0));
        assert_eq!(v.to_screen(DVec2::new(100.0, 0.0)), (400.0, 200.0));
        assert_eq!(v.pixel_of(DVec2::new(-99.9, 99.9)), Some((0, 0)));
        assert_eq!(v.pixel_of(DVec2::new(0.0, 150.0)), None);
        let back = v.to_world(0, 0);
        assert!((back - DVec2::new(-99.75, 99.75)).length() < 1e-9);
    }

    #[test]
    fn thin_views_are_widened() {
        let view = Rect {
            min: DVec2::new(0.0, 0.0),
            max: DVec2::new(1000.0, 10.0),
        };
        let v = Viewport::fit(view, 1000);
        assert_eq!(v.height, 500);
        assert!(v.view.min.y <= 0.0 && v.view.max.y >= 10.0);
        assert!((v.scale - 1.0).abs() < 1e-12);
    }
}
