//! Property test of footprint repair on random, often self-intersecting,
//! rings: the result follows the model's conventions and is valid, keeps all
//! ground the input covered, and adds no ground outside the input's rings.

use citypvs::input::repair::repair_footprint;
use citypvs::model::{
    Polygon, Ring, distance_to_segment, point_in_multipolygon, point_in_ring, polygon_edges,
    ring_edges, ring_signed_area2,
};
use geo::Validation;
use glam::DVec2;
use proptest::prelude::*;

/// Winding number of `ring` around `p`.
fn winding(p: DVec2, ring: &[DVec2]) -> i32 {
    let mut w = 0;
    for (a, b) in ring_edges(ring) {
        if a.y <= p.y {
            if b.y > p.y && (b - a).perp_dot(p - a) > 0.0 {
                w += 1;
            }
        } else if b.y <= p.y && (b - a).perp_dot(p - a) < 0.0 {
            w -= 1;
        }
    }
    w
}

fn ring_strategy() -> impl Strategy<Value = Ring> {
    prop::collection::vec((0.0f64..100.0, 0.0f64..100.0), 3..10)
        .prop_map(|pts| pts.into_iter().map(|(x, y)| DVec2::new(x, y)).collect())
}

fn to_geo(p: &Polygon) -> geo::Polygon<f64> {
    let ring = |r: &Ring| -> geo::LineString<f64> {
        r.iter()
            .chain(r.first())
            .map(|p| geo::coord! { x: p.x, y: p.y })
            .collect()
    };
    geo::Polygon::new(ring(&p.exterior), p.holes.iter().map(ring).collect())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn repair_is_valid_and_keeps_covered_ground(
        rings in prop::collection::vec(ring_strategy(), 1..3),
        separate in any::<bool>(),
    ) {
        // Either one polygon with holes, or each ring a polygon of its own.
        let raw: Vec<Vec<Ring>> = if separate {
            rings.iter().map(|r| vec![r.clone()]).collect()
        } else {
            vec![rings.clone()]
        };
        let repaired = repair_footprint(&raw, true);
        let out = &repaired.footprint;
        for p in out {
            prop_assert!(p.exterior.len() >= 3);
            prop_assert!(ring_signed_area2(&p.exterior) > 0.0);
            for h in &p.holes {
                prop_assert!(ring_signed_area2(h) < 0.0);
            }
        }
        let shapes = geo::MultiPolygon::new(out.iter().map(to_geo).collect());
        prop_assert!(shapes.is_valid(), "{:?}: {:?}", shapes.validation_errors(), out);

        let edges: Vec<(DVec2, DVec2)> = rings.iter().flat_map(|r| ring_edges(r)).collect();
        let out_edges: Vec<(DVec2, DVec2)> = out.iter().flat_map(polygon_edges).collect();
        let near = |p: DVec2, edges: &[(DVec2, DVec2)]| {
            edges.iter().any(|&(a, b)| distance_to_segment(p, a, b) < 1e-3)
        };
        for i in 0..25 {
            for j in 0..25 {
                let p = DVec2::new(i as f64 * 4.0 + 0.731, j as f64 * 4.0 + 0.419);
                if near(p, &edges) || near(p, &out_edges) {
                    continue;
                }
                // Covered ground: inside a polygon (even-odd over its rings).
                let covered = raw.iter().any(|rings| {
                    rings.iter().filter(|r| point_in_ring(p, r)).count() % 2 == 1
                });
                let inside_out = point_in_multipolygon(p, out);
                if covered {
                    prop_assert!(inside_out, "lost ground at {p}: {raw:?} -> {out:?}");
                }
                if inside_out {
                    let enclosed = rings.iter().any(|r| winding(p, r) != 0);
                    prop_assert!(enclosed, "added ground at {p}: {raw:?} -> {out:?}");
                }
            }
        }
    }
}
