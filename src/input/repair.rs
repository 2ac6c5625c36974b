//! Repair of footprints in local metres: closing-vertex, duplicate and
//! collinear vertices, tiny spikes, winding order, degenerate rings, and
//! (with geo's `BooleanOps`) self-intersecting polygons and overlapping
//! polygons of one building. The result follows the model's conventions.

use geo::bool_ops::{FillRule, OpType};
use geo::{BooleanOps, Validation};
use glam::DVec2;

use crate::geometry::convert::{open_ring_from_geo, polygon_to_geo};
use crate::model::{MultiPolygon, Polygon, Ring, point_in_ring, ring_signed_area2};

/// Vertices closer than this (metres) are duplicates.
const DUPLICATE_TOLERANCE: f64 = 1e-6;
/// A vertex this close (metres) to the straight line through its neighbours,
/// and between them, is collinear and carries no shape.
const COLLINEAR_TOLERANCE: f64 = 1e-6;
/// A spike (the boundary going out and straight back) narrower than this
/// (metres) is cut off.
const SPIKE_WIDTH: f64 = 1e-3;
/// Rings with less area than this (square metres) are degenerate.
const MIN_RING_AREA: f64 = 1e-4;

/// A footprint as read: polygons whose first ring is the exterior, rings open
/// (no repeated closing vertex), in local metres, any winding.
pub type RawFootprint = Vec<Vec<Ring>>;

/// A repaired footprint and what was done to get it.
#[derive(Debug, Default)]
pub struct Repaired {
    /// Valid polygons (CCW exteriors, CW holes, open rings); empty when
    /// nothing usable was left.
    pub footprint: MultiPolygon,
    /// One note per kind of repair, e.g. "2 duplicate vertices removed".
    pub notes: Vec<String>,
}

/// Counts of the vertex-level repairs of one ring.
#[derive(Default)]
struct VertexFixes {
    duplicates: usize,
    collinear: usize,
    spikes: usize,
}

impl VertexFixes {
    fn notes(&self, notes: &mut Vec<String>) {
        for (count, what) in [
            (self.duplicates, "duplicate vertices removed"),
            (self.collinear, "collinear vertices removed"),
            (self.spikes, "spike vertices removed"),
        ] {
            if count > 0 {
                notes.push(format!("{count} {what}"));
            }
        }
    }
}

/// What to do with vertex `b` between `a` and `c`.
fn is_removable(a: DVec2, b: DVec2, c: DVec2, fixes: &mut VertexFixes) -> bool {
    let ab = b - a;
    let bc = c - b;
    if ab.length() <= DUPLICATE_TOLERANCE || bc.length() <= DUPLICATE_TOLERANCE {
        fixes.duplicates += 1;
        return true;
    }
    let cross = ab.perp_dot(bc).abs();
    if ab.dot(bc) >= 0.0 {
        let ac = (c - a).length();
        if ac > 0.0 && cross / ac <= COLLINEAR_TOLERANCE {
            fixes.collinear += 1;
            return true;
        }
    } else {
        let width = cross / ab.length().max(bc.length());
        if width <= SPIKE_WIDTH {
            fixes.spikes += 1;
            return true;
        }
    }
    false
}

/// Remove duplicate and collinear vertices and tiny spikes until none is left.
fn clean_ring(ring: &[DVec2], fixes: &mut VertexFixes) -> Ring {
    let mut points: Ring = ring.to_vec();
    loop {
        let n = points.len();
        if n < 3 {
            return points;
        }
        let mut kept: Ring = Vec::with_capacity(n);
        for i in 0..n {
            let a = *kept.last().unwrap_or(&points[n - 1]);
            let c = points[(i + 1) % n];
            if !is_removable(a, points[i], c, fixes) {
                kept.push(points[i]);
            }
        }
        if kept.len() == n {
            return kept;
        }
        points = kept;
    }
}

/// True when a cleaned ring still encloses some area.
fn is_usable(ring: &[DVec2]) -> bool {
    ring.len() >= 3 && 0.5 * ring_signed_area2(ring).abs() >= MIN_RING_AREA
}

/// Orient a ring counter-clockwise (`ccw`) or clockwise; true if it was reversed.
fn orient(ring: &mut Ring, ccw: bool) -> bool {
    if (ring_signed_area2(ring) > 0.0) != ccw {
        ring.reverse();
        true
    } else {
        false
    }
}

/// Union with the non-zero fill rule: every point enclosed by any ring with a
/// non-zero winding number is kept, so no covered ground is lost.
fn union_nonzero(polygons: Vec<geo::Polygon<f64>>) -> Vec<Polygon> {
    let subject = geo::MultiPolygon::new(polygons);
    let empty = geo::MultiPolygon::<f64>::new(Vec::new());
    let united = subject.boolean_op_with_fill_rule(&empty, OpType::Union, FillRule::NonZero);
    let polygons: Vec<Polygon> = united
        .0
        .iter()
        .filter_map(|p| {
            let mut ignored = VertexFixes::default();
            let mut exterior = clean_ring(&open_ring_from_geo(p.exterior()), &mut ignored);
            if !is_usable(&exterior) {
                return None;
            }
            orient(&mut exterior, true);
            let holes = p
                .interiors()
                .iter()
                .map(|h| clean_ring(&open_ring_from_geo(h), &mut ignored))
                .filter(|h| is_usable(h))
                .map(|mut h| {
                    orient(&mut h, false);
                    h
                })
                .collect();
            Some(Polygon { exterior, holes })
        })
        .collect();
    if geo::MultiPolygon::new(polygons.iter().map(polygon_to_geo).collect()).is_valid() {
        polygons
    } else {
        regroup_holes(polygons)
    }
}

/// In near-degenerate cases the overlay gives a hole to the wrong outer
/// ring (seen: a hole placed in a small island of another hole). Its rings
/// are still the union's boundary and do not cross, so each hole is given
/// back to the innermost outer ring that holds a point just inside the hole
/// beside the middle of its longest edge: a point no island in the hole
/// reaches. A hole that no outer ring holds stays where it was.
fn regroup_holes(polygons: Vec<Polygon>) -> Vec<Polygon> {
    let mut outers: Vec<Polygon> = Vec::with_capacity(polygons.len());
    let mut holes: Vec<(usize, Ring)> = Vec::new();
    for (i, p) in polygons.into_iter().enumerate() {
        holes.extend(p.holes.into_iter().map(|h| (i, h)));
        outers.push(Polygon {
            exterior: p.exterior,
            holes: Vec::new(),
        });
    }
    let areas: Vec<f64> = outers
        .iter()
        .map(|p| ring_signed_area2(&p.exterior))
        .collect();
    for (first_owner, hole) in holes {
        let owner = probe_inside_hole(&hole)
            .and_then(|probe| {
                (0..outers.len())
                    .filter(|&i| point_in_ring(probe, &outers[i].exterior))
                    .min_by(|&a, &b| areas[a].total_cmp(&areas[b]))
            })
            .unwrap_or(first_owner);
        outers[owner].holes.push(hole);
    }
    outers
}

/// A point inside the (clockwise) hole, a millionth of its longest edge in
/// from that edge's middle; none when the ring has no edge of any length.
fn probe_inside_hole(hole: &[DVec2]) -> Option<DVec2> {
    let (a, b) = (0..hole.len())
        .map(|i| (hole[i], hole[(i + 1) % hole.len()]))
        .max_by(|x, y| x.0.distance(x.1).total_cmp(&y.0.distance(y.1)))?;
    let d = b - a;
    if d.length() == 0.0 {
        return None;
    }
    // Clockwise: the enclosed side is on the right of a -> b.
    Some(0.5 * (a + b) + 1e-6 * DVec2::new(d.y, -d.x))
}

/// Repair one building's footprint. Polygons that stay invalid after repair,
/// or have no area, are left out (and noted). Reversed rings are noted only
/// when `winding_matters` (GeoJSON prescribes a winding; OSM does not).
pub fn repair_footprint(raw: &RawFootprint, winding_matters: bool) -> Repaired {
    let mut notes = Vec::new();
    let mut fixes = VertexFixes::default();
    let mut reversed = 0;
    let mut dropped_holes = 0;
    let mut dropped_polygons = 0;
    let mut rebuilt = Vec::new();
    let mut valid = Vec::with_capacity(raw.len());
    for rings in raw {
        let Some((exterior, holes)) = rings.split_first() else {
            continue;
        };
        let mut exterior = clean_ring(exterior, &mut fixes);
        if exterior.len() < 3 {
            dropped_polygons += 1;
            continue;
        }
        let mut kept_holes = Vec::new();
        for hole in holes {
            let hole = clean_ring(hole, &mut fixes);
            if hole.len() >= 3 {
                kept_holes.push(hole);
            } else {
                dropped_holes += 1;
            }
        }
        reversed += orient(&mut exterior, true) as usize;
        for hole in &mut kept_holes {
            reversed += orient(hole, false) as usize;
        }
        let polygon = Polygon {
            exterior,
            holes: kept_holes,
        };
        // Already oriented: the conversion keeps every ring as it is (it would
        // only turn a ring of exactly zero area, which bounds nothing).
        let shape = polygon_to_geo(&polygon);
        match shape.check_validation() {
            Ok(()) if is_usable(&polygon.exterior) => {
                let before = polygon.holes.len();
                let holes: Vec<Ring> = polygon.holes.into_iter().filter(|h| is_usable(h)).collect();
                dropped_holes += before - holes.len();
                valid.push(Polygon {
                    exterior: polygon.exterior,
                    holes,
                });
            }
            Ok(()) => dropped_polygons += 1,
            Err(problem) => {
                let fixed = union_nonzero(vec![shape]);
                rebuilt.push(format!(
                    "invalid polygon ({problem}) rebuilt with geo BooleanOps union (non-zero fill) into {} polygons",
                    fixed.len()
                ));
                valid.extend(fixed);
            }
        }
    }
    fixes.notes(&mut notes);
    if reversed > 0 && winding_matters {
        notes.push(format!("{reversed} rings with the wrong winding reversed"));
    }
    if dropped_holes > 0 {
        notes.push(format!("{dropped_holes} holes with no area removed"));
    }
    if dropped_polygons > 0 {
        notes.push(format!("{dropped_polygons} polygons with no area removed"));
    }
    notes.extend(rebuilt);
    if valid.len() > 1 {
        let shapes: Vec<geo::Polygon<f64>> = valid.iter().map(polygon_to_geo).collect();
        let all = geo::MultiPolygon::new(shapes);
        if let Err(problem) = all.check_validation() {
            let before = valid.len();
            valid = union_nonzero(all.0);
            notes.push(format!(
                "{before} polygons that overlap or share an edge ({problem}) unioned with geo BooleanOps into {}",
                valid.len()
            ));
        }
    }
    Repaired {
        footprint: valid,
        notes,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::multipolygon_area;

    fn ring(points: &[(f64, f64)]) -> Ring {
        points.iter().map(|&(x, y)| DVec2::new(x, y)).collect()
    }

    #[test]
    fn valid_square_is_untouched() {
        let square = ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        let r = repair_footprint(&vec![vec![square.clone()]], true);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
        assert_eq!(r.footprint[0].exterior, square);
    }

    #[test]
    fn clockwise_duplicates_collinear_and_spike_are_fixed() {
        let cw = ring(&[
            (0.0, 0.0),
            (0.0, 10.0),
            (0.0, 10.0),
            (10.0, 10.0),
            (15.0, 10.0),
            (10.0, 10.0),
            (10.0, 5.0),
            (10.0, 0.0),
        ]);
        let r = repair_footprint(&vec![vec![cw]], true);
        let p = &r.footprint[0];
        assert_eq!(p.exterior.len(), 4, "{:?}", p.exterior);
        assert!(ring_signed_area2(&p.exterior) > 0.0);
        assert!((multipolygon_area(&r.footprint) - 100.0).abs() < 1e-9);
        let text = r.notes.join("; ");
        for word in ["duplicate", "collinear", "spike", "winding"] {
            assert!(text.contains(word), "{text}");
        }
    }

    #[test]
    fn bowtie_keeps_both_lobes() {
        let bowtie = ring(&[(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)]);
        let r = repair_footprint(&vec![vec![bowtie]], true);
        assert_eq!(r.footprint.len(), 2, "{:?}", r.footprint);
        assert!((multipolygon_area(&r.footprint) - 50.0).abs() < 1e-6);
        assert!(r.notes.iter().any(|n| n.contains("BooleanOps")));
    }

    #[test]
    fn a_hole_given_to_the_wrong_outer_ring_goes_back_to_its_own() {
        // A 100 m square with a courtyard (20..60) holding an island
        // (30..40) and a second courtyard (70..90) that was handed to the
        // island, as the overlay once did.
        let ccw =
            |x0: f64, y0: f64, x1: f64, y1: f64| ring(&[(x0, y0), (x1, y0), (x1, y1), (x0, y1)]);
        let cw = |x0, y0, x1, y1| {
            let mut r = ccw(x0, y0, x1, y1);
            r.reverse();
            r
        };
        let misgrouped = vec![
            Polygon {
                exterior: ccw(0.0, 0.0, 100.0, 100.0),
                holes: vec![cw(20.0, 20.0, 60.0, 60.0)],
            },
            Polygon {
                exterior: ccw(30.0, 30.0, 40.0, 40.0),
                holes: vec![cw(70.0, 70.0, 90.0, 90.0)],
            },
        ];
        let shape =
            |ps: &[Polygon]| geo::MultiPolygon::new(ps.iter().map(polygon_to_geo).collect());
        assert!(!shape(&misgrouped).is_valid());
        let fixed = regroup_holes(misgrouped);
        assert!(shape(&fixed).is_valid(), "{fixed:?}");
        assert_eq!(fixed[0].holes.len(), 2);
        assert!(fixed[1].holes.is_empty());
        assert!((multipolygon_area(&fixed) - (10_000.0 - 1_600.0 - 400.0 + 100.0)).abs() < 1e-9);
    }

    #[test]
    fn overlapping_polygons_are_unioned() {
        let a = ring(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        let b = ring(&[(5.0, 5.0), (15.0, 5.0), (15.0, 15.0), (5.0, 15.0)]);
        let r = repair_footprint(&vec![vec![a], vec![b]], true);
        assert_eq!(r.footprint.len(), 1);
        assert!((multipolygon_area(&r.footprint) - 175.0).abs() < 1e-6);
    }

    #[test]
    fn zero_area_polygon_is_dropped() {
        let flat = ring(&[(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)]);
        let r = repair_footprint(&vec![vec![flat]], true);
        assert!(r.footprint.is_empty());
        assert!(!r.notes.is_empty());
    }
}
