//! Conservative erosion: an area minus closed strips along its edges and
//! polygons circumscribed about the discs at its reflex corners, so the
//! result lies inside the exact erosion (METHOD.md 4: tangent lines around
//! the removed discs, never chords).

use std::f64::consts::PI;

use geo::BooleanOps;
use geo::bool_ops::FillRule;
use glam::DVec2;

use super::convert::{multipolygon_from_geo, polygon_to_geo};
use crate::model::{MultiPolygon, Polygon, multipolygon_bounds, ring_signed_area2};

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

/// One polygon minus the strips along all its edges and the discs around
/// its reflex corners. Eroding the polygons of a multipolygon separately is
/// exact because their interiors are disjoint: the segment from a point of
/// one polygon to the boundary of another crosses the first one's boundary.
///
/// Why strips and reflex discs suffice: for a point inside the polygon, the
/// nearest boundary point is either the foot of a perpendicular inside an
/// edge (covered by that edge's strip) or a reflex corner (covered by its
/// disc); a convex corner is never nearest to an inside point, since the
/// directions for which it is nearest point out of the polygon.
fn erode_polygon(polygon: &Polygon, radius: f64) -> MultiPolygon {
    let bounds = multipolygon_bounds(std::slice::from_ref(polygon));
    // A disc of the radius must fit inside the polygon, hence inside its box.
    if bounds.is_empty() || bounds.width() <= 2.0 * radius || bounds.height() <= 2.0 * radius {
        return Vec::new();
    }
    let mut cut: Vec<geo::Polygon<f64>> = Vec::new();
    let solid_on_left =
        std::iter::once((&polygon.exterior, true)).chain(polygon.holes.iter().map(|h| (h, false)));
    for (ring, exterior) in solid_on_left {
        let mut ring: Vec<DVec2> = ring.clone();
        ring.dedup();
        while ring.len() > 1 && ring.first() == ring.last() {
            ring.pop();
        }
        // Orient so that the solid lies left of every edge: exteriors
        // counter-clockwise, holes clockwise.
        if (ring_signed_area2(&ring) > 0.0) != exterior {
            ring.reverse();
        }
        let n = ring.len();
        for i in 0..n {
            let (prev, v, next) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            cut.push(strip(v, next, radius));
            // Reflex (or straight, to be safe) where the boundary turns right.
            if (v - prev).perp_dot(next - v) <= 0.0 {
                cut.push(disc(v, radius));
            }
        }
    }
    let cut = geo::MultiPolygon::new(cut);
    let rest = polygon_to_geo(polygon).difference_with_fill_rule(&cut, FillRule::NonZero);
    multipolygon_from_geo(&rest, MIN_PIECE_AREA)
}

/// A relative widening of the cut shapes that covers the rounding of their
/// corner coordinates (sin, cos, normalisation).
const ROUNDING_SLACK: f64 = 1e-12;

/// The closed rectangle of points within `radius` of the segment a-b whose
/// projection onto the segment's line falls inside the segment, grown a
/// little. `a != b`.
fn strip(a: DVec2, b: DVec2, radius: f64) -> geo::Polygon<f64> {
    let d = (b - a).normalize();
    let grow = radius * ROUNDING_SLACK;
    let along = d * grow;
    let side = d.perp() * (radius + grow);
    let corners = [
        a - along - side,
        b + along - side,
        b + along + side,
        a - along + side,
    ];
    geo::Polygon::new(
        corners
            .iter()
            .map(|p| geo::Coord { x: p.x, y: p.y })
            .collect(),
        Vec::new(),
    )
}

/// Sides of the polygon that circumscribes a corner's disc.
const DISC_SIDES: usize = 16;

/// A regular polygon circumscribed about the disc of `radius` around `c`
/// (its vertices at radius / cos(pi / n)), so it contains the disc.
fn disc(c: DVec2, radius: f64) -> geo::Polygon<f64> {
    let n = DISC_SIDES as f64;
    let r = radius / (PI / n).cos() * (1.0 + ROUNDING_SLACK);
    let ring: Vec<geo::Coord<f64>> = (0..DISC_SIDES)
        .map(|k| {
            let angle = 2.0 * PI * k as f64 / n;
            geo::Coord {
                x: c.x + r * angle.cos(),
                y: c.y + r * angle.sin(),
            }
        })
        .collect();
    geo::Polygon::new(geo::LineString::new(ring), Vec::new())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::convert::multipolygon_from_geo;

    fn ring_of(p: geo::Polygon<f64>) -> Vec<DVec2> {
        let mp = multipolygon_from_geo(&geo::MultiPolygon::new(vec![p]), 0.0);
        assert_eq!(mp.len(), 1);
        mp[0].exterior.clone()
    }

    #[test]
    fn disc_polygon_contains_the_disc() {
        let c = DVec2::new(3.0, -2.0);
        let ring = ring_of(disc(c, 1.5));
        assert_eq!(ring.len(), DISC_SIDES);
        for i in 0..ring.len() {
            let (p, q) = (ring[i], ring[(i + 1) % ring.len()]);
            for s in 0..=100 {
                let x = p + (q - p) * (s as f64 / 100.0);
                assert!(x.distance(c) >= 1.5 - 1e-12);
            }
        }
    }

    #[test]
    fn strip_covers_the_perpendicular_band() {
        let (a, b) = (DVec2::new(1.0, 2.0), DVec2::new(7.0, -3.0));
        let ring = ring_of(strip(a, b, 1.5));
        let d = (b - a).normalize();
        for p in &ring {
            let t = (*p - a).dot(d);
            let off = (*p - a).perp_dot(d).abs();
            assert!(t <= 0.0 || t >= a.distance(b));
            assert!(off >= 1.5);
        }
    }
}
