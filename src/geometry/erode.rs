//! Conservative erosion: an area minus polygons that circumscribe the
//! capsules (segment plus disc) around every boundary edge, so the result
//! lies inside the exact erosion (METHOD.md 4: tangent lines around the
//! removed discs, never chords).

use std::f64::consts::PI;

use geo::BooleanOps;
use geo::bool_ops::FillRule;
use glam::DVec2;

use super::convert::{multipolygon_from_geo, polygon_to_geo};
use crate::model::{MultiPolygon, Polygon, multipolygon_bounds, polygon_edges};

/// Extra erosion in metres on top of eps. It absorbs the boolean
/// operation's snapping to its integer grid (about 1e-7 m for a block a
/// hundred metres across, 1e-5 m for ten kilometres) and the rounding of the
/// capsule corners, so the polygonal result can never reach closer than eps
/// to the boundary.
pub const EROSION_SAFETY_MARGIN: f64 = 1e-3;

/// Eroded pieces smaller than this (square metres) are dropped; dropping a
/// piece only makes the result smaller, which stays conservative.
pub const MIN_PIECE_AREA: f64 = 1e-6;

/// Erode each polygon of `area` by `eps` plus the safety margin.
pub fn erode(area: &MultiPolygon, eps: f64) -> MultiPolygon {
    if !(eps >= 0.0) || !eps.is_finite() {
        // Nothing sensible to return for a meaningless distance; the empty
        // set is the conservative answer.
        return Vec::new();
    }
    let radius = eps + EROSION_SAFETY_MARGIN;
    area.iter()
        .flat_map(|polygon| erode_polygon(polygon, radius))
        .collect()
}

/// One polygon minus the circumscribed capsules of all its edges. Eroding
/// the polygons of a multipolygon separately is exact because their
/// interiors are disjoint: the segment from a point of one polygon to the
/// boundary of another crosses the first one's boundary.
fn erode_polygon(polygon: &Polygon, radius: f64) -> MultiPolygon {
    let bounds = multipolygon_bounds(std::slice::from_ref(polygon));
    // A disc of the radius must fit inside the polygon, hence inside its box.
    if bounds.is_empty() || bounds.width() <= 2.0 * radius || bounds.height() <= 2.0 * radius {
        return Vec::new();
    }
    let capsules: Vec<geo::Polygon<f64>> = polygon_edges(polygon)
        .filter(|(a, b)| a != b)
        .map(|(a, b)| capsule(a, b, radius))
        .collect();
    let cut = geo::MultiPolygon::new(capsules);
    let rest = polygon_to_geo(polygon).difference_with_fill_rule(&cut, FillRule::NonZero);
    multipolygon_from_geo(&rest, MIN_PIECE_AREA)
}

/// A counter-clockwise octagon-ended polygon containing every point within
/// `radius` of the segment a-b: the convex hull of two regular octagons
/// circumscribed about the discs at a and b, turned so that two of their
/// sides lie along the segment's offset lines.
fn capsule(a: DVec2, b: DVec2, radius: f64) -> geo::Polygon<f64> {
    let dir = (b - a).normalize();
    let phi = dir.y.atan2(dir.x);
    // Vertices of a circumscribed regular octagon lie at radius / cos(pi/8);
    // a relative 1e-12 more covers the rounding of sin and cos.
    let r = radius / (PI / 8.0).cos() * (1.0 + 1e-12);
    let corner = |centre: DVec2, k: i32| {
        let angle = phi + (2 * k + 1) as f64 * PI / 8.0;
        geo::Coord {
            x: centre.x + r * angle.cos(),
            y: centre.y + r * angle.sin(),
        }
    };
    // Front half of the octagon at b (angles phi -3pi/8 .. phi +3pi/8), then
    // the back half of the octagon at a (phi +5pi/8 .. phi +11pi/8).
    let mut ring: Vec<geo::Coord<f64>> = (-2..2).map(|k| corner(b, k)).collect();
    ring.extend((2..6).map(|k| corner(a, k)));
    geo::Polygon::new(geo::LineString::new(ring), Vec::new())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::distance_to_segment;

    #[test]
    fn capsule_contains_the_exact_capsule() {
        let a = DVec2::new(1.0, 2.0);
        let b = DVec2::new(7.0, -3.0);
        let cap = crate::geometry::convert::multipolygon_from_geo(
            &geo::MultiPolygon::new(vec![capsule(a, b, 1.5)]),
            0.0,
        );
        assert_eq!(cap.len(), 1);
        let ring = &cap[0].exterior;
        assert_eq!(ring.len(), 8);
        // Every edge of the capsule polygon stays at least the radius from
        // the segment: sample along each edge.
        for i in 0..ring.len() {
            let (p, q) = (ring[i], ring[(i + 1) % ring.len()]);
            for s in 0..=100 {
                let x = p + (q - p) * (s as f64 / 100.0);
                assert!(distance_to_segment(x, a, b) >= 1.5 - 1e-12);
            }
        }
    }
}
