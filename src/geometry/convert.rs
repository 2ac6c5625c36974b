//! Conversion between the model's polygons (open rings, CCW exteriors, CW
//! holes) and `geo` polygons (closed rings), and the clean-up that puts the
//! output of `geo`'s boolean operations back into the model's conventions.

use glam::DVec2;

use crate::model::{MultiPolygon, Polygon, Ring, ring_signed_area2};

/// A model ring as a closed `geo` line string, counter-clockwise when `ccw`
/// and clockwise otherwise (whatever the input's orientation), so that the
/// non-zero and positive fill rules of the boolean operations hold.
fn ring_to_geo(ring: &[DVec2], ccw: bool) -> geo::LineString<f64> {
    let mut coords: Vec<geo::Coord<f64>> =
        ring.iter().map(|p| geo::Coord { x: p.x, y: p.y }).collect();
    if (ring_signed_area2(ring) < 0.0) == ccw {
        coords.reverse();
    }
    if let Some(&first) = coords.first() {
        coords.push(first);
    }
    geo::LineString::new(coords)
}

/// A model polygon as a `geo` polygon: exterior counter-clockwise, holes
/// clockwise.
pub fn polygon_to_geo(polygon: &Polygon) -> geo::Polygon<f64> {
    geo::Polygon::new(
        ring_to_geo(&polygon.exterior, true),
        polygon
            .holes
            .iter()
            .map(|h| ring_to_geo(h, false))
            .collect(),
    )
}

/// A model multipolygon as a `geo` multipolygon.
pub fn multipolygon_to_geo(mp: &[Polygon]) -> geo::MultiPolygon<f64> {
    geo::MultiPolygon::new(mp.iter().map(polygon_to_geo).collect())
}

/// A `geo` ring's points as an open model ring, as they are (only the
/// closing vertex dropped): for callers that clean rings themselves.
pub fn open_ring_from_geo(ring: &geo::LineString<f64>) -> Ring {
    let mut points: Ring = ring.coords().map(|c| DVec2::new(c.x, c.y)).collect();
    if points.len() > 1 && points.first() == points.last() {
        points.pop();
    }
    points
}

/// A `geo` ring as an open model ring without repeated consecutive vertices
/// (the closing vertex included), oriented counter-clockwise when `ccw` and
/// clockwise otherwise. `None` when fewer than three vertices remain or the
/// ring encloses no area: such a ring bounds a set of measure zero.
fn ring_from_geo(ring: &geo::LineString<f64>, ccw: bool) -> Option<Ring> {
    let mut out: Ring = Vec::with_capacity(ring.0.len());
    for c in &ring.0 {
        let p = DVec2::new(c.x, c.y);
        if out.last() != Some(&p) {
            out.push(p);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    if out.len() < 3 {
        return None;
    }
    let area2 = ring_signed_area2(&out);
    if area2 == 0.0 || !area2.is_finite() {
        return None;
    }
    if (area2 > 0.0) != ccw {
        out.reverse();
    }
    Some(out)
}

/// A `geo` multipolygon in the model's conventions: open rings, CCW
/// exteriors, CW holes, no repeated consecutive vertices. Rings that enclose
/// no area are dropped (they bound sets of measure zero), and so are
/// polygons whose exterior encloses less than `min_exterior_area` square
/// metres (use 0.0 to keep every polygon with positive area).
pub fn multipolygon_from_geo(mp: &geo::MultiPolygon<f64>, min_exterior_area: f64) -> MultiPolygon {
    let mut out = Vec::with_capacity(mp.0.len());
    for polygon in &mp.0 {
        let Some(exterior) = ring_from_geo(polygon.exterior(), true) else {
            continue;
        };
        if 0.5 * ring_signed_area2(&exterior) < min_exterior_area {
            continue;
        }
        let holes = polygon
            .interiors()
            .iter()
            .filter_map(|h| ring_from_geo(h, false))
            .collect();
        out.push(Polygon { exterior, holes });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_orientation_and_opens_rings() {
        let exterior = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(4.0, 0.0),
            DVec2::new(4.0, 4.0),
            DVec2::new(0.0, 4.0),
        ];
        let hole = vec![
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 2.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(2.0, 1.0),
        ];
        let p = Polygon {
            exterior: exterior.clone(),
            holes: vec![hole.clone()],
        };
        let g = multipolygon_to_geo(std::slice::from_ref(&p));
        assert_eq!(g.0[0].exterior().0.len(), 5);
        let back = multipolygon_from_geo(&g, 0.0);
        assert_eq!(back, vec![p]);
    }

    #[test]
    fn degenerate_rings_are_dropped_and_orientation_fixed() {
        let cw = geo::LineString::from(vec![(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]);
        let flat = geo::LineString::from(vec![(0.2, 0.5), (0.4, 0.5), (0.6, 0.5)]);
        let mp = geo::MultiPolygon::new(vec![geo::Polygon::new(cw, vec![flat])]);
        let out = multipolygon_from_geo(&mp, 0.0);
        assert_eq!(out.len(), 1);
        assert!(ring_signed_area2(&out[0].exterior) > 0.0);
        assert!(out[0].holes.is_empty());
        assert!(multipolygon_from_geo(&mp, 2.0).is_empty());
    }
}
