//! Conservative erosion: an area minus closed strips along its edges and
//! polygons circumscribed about the discs at its reflex corners, so the
//! result lies inside the exact erosion (docs/METHOD.md §4: tangent lines around
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
    if eps.is_nan() || eps < 0.0 || eps.is_infinite() {
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
    let rings: Vec<Vec<DVec2>> = std::iter::once(solid_on_left(&polygon.exterior, true))
        .chain(polygon.holes.iter().map(|h| solid_on_left(h, false)))
        .collect();
    if rings.len() == 1 && (0..rings[0].len()).all(|i| !is_reflex_or_straight(&rings[0], i)) {
        return erode_convex(&rings[0], radius);
    }
    let mut cut: Vec<geo::Polygon<f64>> = Vec::new();
    for ring in &rings {
        let n = ring.len();
        for i in 0..n {
            let (prev, v, next) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
            cut.push(strip(v, next, radius));
            cut.extend(corner_wedge(prev, v, next, radius));
        }
    }
    let cut = geo::MultiPolygon::new(cut);
    let rest = polygon_to_geo(polygon).difference_with_fill_rule(&cut, FillRule::NonZero);
    multipolygon_from_geo(&rest, MIN_PIECE_AREA)
}

/// The ring without repeated consecutive vertices, oriented so that the
/// solid lies left of every edge: counter-clockwise for an exterior,
/// clockwise for a hole.
fn solid_on_left(ring: &[DVec2], exterior: bool) -> Vec<DVec2> {
    let mut ring = ring.to_vec();
    ring.dedup();
    while ring.len() > 1 && ring.first() == ring.last() {
        ring.pop();
    }
    if (ring_signed_area2(&ring) > 0.0) != exterior {
        ring.reverse();
    }
    ring
}

/// Whether the boundary turns right (reflex corner) or goes straight on at
/// vertex `i` of a solid-on-the-left ring. Straight counts, to be safe.
fn is_reflex_or_straight(ring: &[DVec2], i: usize) -> bool {
    let n = ring.len();
    let (prev, v, next) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
    (v - prev).perp_dot(next - v) <= 0.0
}

/// Erosion of a strictly convex polygon (counter-clockwise, no holes): the
/// intersection of its edges' inner half-planes moved in by `radius`. For a
/// point inside a convex polygon the distance to the boundary is the least
/// distance to the edges' lines, so this is the exact erosion; the rounding
/// of the clipping (about 1e-12 m) is far below the safety margin.
fn erode_convex(ring: &[DVec2], radius: f64) -> MultiPolygon {
    let n = ring.len();
    if n < 3 {
        return Vec::new();
    }
    let mut shape: Vec<DVec2> = ring.to_vec();
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        let inward = (b - a).perp().normalize();
        // Keep the points p with inward . (p - a) >= radius.
        let side = |p: DVec2| inward.dot(p - a) - radius;
        let mut clipped = Vec::with_capacity(shape.len() + 1);
        for k in 0..shape.len() {
            let (p, q) = (shape[k], shape[(k + 1) % shape.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                clipped.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                clipped.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
        shape = clipped;
        if shape.len() < 3 {
            return Vec::new();
        }
    }
    // Dropping vertices of a convex polygon only shrinks it.
    shape.dedup();
    while shape.len() > 1 && shape.first() == shape.last() {
        shape.pop();
    }
    if shape.len() < 3 || 0.5 * ring_signed_area2(&shape) < MIN_PIECE_AREA {
        return Vec::new();
    }
    vec![Polygon {
        exterior: shape,
        holes: Vec::new(),
    }]
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

/// The largest angle one side of a corner wedge spans around the corner.
/// Its vertices then lie at most radius / cos(pi / 8), 8% of the radius,
/// beyond the circle.
const WEDGE_STEP: f64 = PI / 4.0;

/// At a reflex corner v (the boundary prev-v-next turns right, solid on the
/// left), a polygon containing the part of the disc of `radius` around v
/// that the two edges' strips leave uncovered: the sector between the
/// edges' inward normals. Its outer sides are tangent to the circle
/// (circumscribed, never chords). `None` at convex corners and where the
/// boundary goes straight on, where the strips cover the whole disc.
fn corner_wedge(prev: DVec2, v: DVec2, next: DVec2, radius: f64) -> Option<geo::Polygon<f64>> {
    let d1 = (v - prev).normalize();
    let d2 = (next - v).normalize();
    let cross = d1.perp_dot(d2);
    let dot = d1.dot(d2);
    // The turn to the right, in (0, pi]; a spike (turning back) is pi.
    let theta = if cross < 0.0 {
        (-cross).atan2(dot)
    } else if cross == 0.0 && dot < 0.0 {
        PI
    } else {
        return None;
    };
    let steps = (theta / WEDGE_STEP).ceil().max(1.0) as usize;
    let half_step = theta / (2 * steps) as f64;
    let r = radius * (1.0 + ROUNDING_SLACK);
    let corner = r / half_step.cos();
    // From the inward normal of the outgoing edge counter-clockwise to that
    // of the incoming edge.
    let n2 = d2.perp();
    let start = n2.y.atan2(n2.x);
    let mut ring = vec![v, v + n2 * r];
    ring.extend(
        (0..steps).map(|k| v + DVec2::from_angle(start + (2 * k + 1) as f64 * half_step) * corner),
    );
    ring.push(v + d1.perp() * r);
    Some(geo::Polygon::new(
        ring.iter().map(|p| geo::Coord { x: p.x, y: p.y }).collect(),
        Vec::new(),
    ))
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
    fn strips_and_wedge_cover_the_disc_at_reflex_corners() {
        use crate::model::point_in_ring;
        let v = DVec2::new(3.0, -2.0);
        let radius = 1.5;
        for turn_deg in [1.0, 30.0, 45.0, 90.0, 91.0, 135.0, 170.0, 179.9] {
            let d1 = DVec2::from_angle(0.3);
            let d2 = DVec2::from_angle(0.3 - f64::to_radians(turn_deg));
            let (prev, next) = (v - d1 * 4.0, v + d2 * 4.0);
            let wedge = ring_of(corner_wedge(prev, v, next, radius).unwrap());
            // The wedge's outer sides stay outside the circle.
            for i in 1..wedge.len() - 1 {
                let (p, q) = (wedge[i], wedge[i + 1]);
                for s in 0..=50 {
                    let x = p + (q - p) * (s as f64 / 50.0);
                    assert!(x.distance(v) >= radius * (1.0 - 1e-12), "turn {turn_deg}");
                }
            }
            // Strips plus wedge cover the disc.
            let s1 = ring_of(strip(prev, v, radius));
            let s2 = ring_of(strip(v, next, radius));
            for k in 0..720 {
                for f in [0.3, 0.9, 0.999] {
                    let p = v + DVec2::from_angle(k as f64 / 720.0 * 2.0 * PI) * radius * f;
                    assert!(
                        point_in_ring(p, &s1) || point_in_ring(p, &s2) || point_in_ring(p, &wedge),
                        "turn {turn_deg}: {p} uncovered"
                    );
                }
            }
        }
        // Convex corners and straight runs need no wedge.
        let (a, b) = (DVec2::ZERO, DVec2::X);
        assert!(corner_wedge(a, b, DVec2::new(1.0, 1.0), radius).is_none());
        assert!(corner_wedge(a, b, DVec2::new(2.0, 0.0), radius).is_none());
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
