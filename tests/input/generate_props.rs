//! Property tests of the generator over random seeds and sizes: the count,
//! ring orientation and size, heights, no two footprints overlapping, and
//! shared walls meeting end point to end point.

use citypvs::generate::{GRID_ROTATION_DEG, GenerateParams, Kind, generate_buildings};
use citypvs::model::ring_signed_area2;
use glam::DVec2;
use proptest::prelude::*;

/// A ring turned into the street grid's frame (undo the rotation).
fn to_grid(ring: &[DVec2]) -> Vec<DVec2> {
    let (s, c) = (-GRID_ROTATION_DEG).to_radians().sin_cos();
    ring.iter()
        .map(|p| DVec2::new(p.x * c - p.y * s, p.x * s + p.y * c))
        .collect()
}

/// True when `p` lies inside the segment a-b, away from its end points.
fn strictly_inside_segment(p: DVec2, a: DVec2, b: DVec2) -> bool {
    let d = b - a;
    let t = (p - a).dot(d) / d.length_squared();
    let off_line = (p - a).perp_dot(d).abs() / d.length();
    off_line < 1e-6 && t * d.length() > 1e-6 && (1.0 - t) * d.length() > 1e-6
}

/// Bounding box of a ring in the street grid's frame, where every generated
/// footprint is an axis-aligned rectangle.
fn grid_box(ring: &[DVec2]) -> (DVec2, DVec2) {
    to_grid(ring).into_iter().fold(
        (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
        |(lo, hi), q| (lo.min(q), hi.max(q)),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn any_seed_gives_valid_disjoint_footprints(seed in any::<u64>(), n in 1usize..400) {
        let buildings = generate_buildings(&GenerateParams { buildings: n, seed });
        prop_assert_eq!(buildings.len(), n);
        let boxes: Vec<_> = buildings.iter().map(|b| grid_box(&b.footprint.exterior)).collect();
        for (b, (lo, hi)) in buildings.iter().zip(&boxes) {
            let outer = &b.footprint.exterior;
            prop_assert_eq!(outer.len(), 4);
            prop_assert!(ring_signed_area2(outer) > 2.0 * 60.0, "{} too small or not CCW", b.id);
            // A rectangle: its area equals its grid box's area.
            let box_area = (hi.x - lo.x) * (hi.y - lo.y);
            prop_assert!((0.5 * ring_signed_area2(outer) - box_area).abs() < 1e-6);
            for hole in &b.footprint.holes {
                prop_assert!(ring_signed_area2(hole) < 0.0, "{} hole not CW", b.id);
                let (hlo, hhi) = grid_box(hole);
                prop_assert!(hlo.x > lo.x + 5.0 && hlo.y > lo.y + 5.0 && hhi.x < hi.x - 5.0 && hhi.y < hi.y - 5.0);
            }
            let (min, max) = if b.kind == Kind::Tower { (40.0, 120.0) } else { (6.0, 30.0) };
            prop_assert!((min..=max).contains(&b.height), "{} height {}", b.id, b.height);
        }
        // Rectangles overlap when their intervals overlap on both axes
        // (touching is allowed; 1e-6 m absorbs rounding in the rotation).
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                let (a, b) = (boxes[i], boxes[j]);
                let overlap_x = a.1.x.min(b.1.x) - a.0.x.max(b.0.x);
                let overlap_y = a.1.y.min(b.1.y) - a.0.y.max(b.0.y);
                prop_assert!(
                    overlap_x < 1e-6 || overlap_y < 1e-6,
                    "{} and {} overlap", buildings[i].id, buildings[j].id
                );
                // Where they touch, no corner of one lies inside a wall of the
                // other (no T-junctions: shared walls have shared end points).
                if overlap_x > -1e-6 && overlap_y > -1e-6 {
                    for (p, q) in [(i, j), (j, i)] {
                        let corners = to_grid(&buildings[p].footprint.exterior);
                        let walls = to_grid(&buildings[q].footprint.exterior);
                        for c in &corners {
                            for k in 0..walls.len() {
                                let (a, b) = (walls[k], walls[(k + 1) % walls.len()]);
                                prop_assert!(
                                    !strictly_inside_segment(*c, a, b),
                                    "a corner of {} lies inside a wall of {}",
                                    buildings[p].id, buildings[q].id
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
