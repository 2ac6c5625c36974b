//! Property tests of merging and erosion over random scenes: concave
//! (star-shaped) polygons with and without courtyards, rows of wall-sharing
//! buildings of different depths and heights, overlapping annexes.

use crate::scenes;

use citypvs::geometry::{EROSION_SAFETY_MARGIN, erode, merge_blocks};
use citypvs::model::{MultiPolygon, Polygon, multipolygon_area, point_in_multipolygon};
use glam::DVec2;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use scenes::{assert_model_polygons, boundary_distance, box_points, edge_points, scene};

/// How far beyond eps + margin the polygonal cut may reach: the corner
/// wedges' vertices lie at radius / cos(pi / 8).
fn cut_reach(eps: f64) -> f64 {
    (eps + EROSION_SAFETY_MARGIN) / (std::f64::consts::PI / 8.0).cos() + 1e-6
}

/// Every sample point of the eroded area is inside the original and at
/// least eps from its boundary; every point deep enough inside the original
/// survives the erosion.
fn check_erosion(area: &MultiPolygon, eps: f64, rng: &mut ChaCha8Rng) {
    let eroded = erode(area, eps);
    assert_model_polygons(&eroded);
    let mut samples: Vec<DVec2> = edge_points(&eroded, 8);
    if !eroded.is_empty() {
        samples.extend(
            box_points(rng, &eroded, 300)
                .into_iter()
                .filter(|p| point_in_multipolygon(*p, &eroded)),
        );
    }
    for p in samples {
        let d = boundary_distance(p, area);
        assert!(
            point_in_multipolygon(p, area) || d < 1e-9,
            "eroded point {p} lies outside the area"
        );
        assert!(
            d >= eps - 1e-9,
            "eroded point {p} is only {d} from the boundary (eps {eps})"
        );
    }
    for p in box_points(rng, area, 300) {
        if point_in_multipolygon(p, area) && boundary_distance(p, area) >= cut_reach(eps) {
            assert!(
                point_in_multipolygon(p, &eroded),
                "deep point {p} was eroded away"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn erosion_is_conservative_and_not_much_smaller(seed in any::<u64>(), eps in 0.2f64..3.0) {
        let scene = scene(seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed);
        // Raw footprints (not through the boolean operation) ...
        for b in &scene.buildings {
            check_erosion(&b.footprint, eps, &mut rng);
        }
        // ... convex polygons with vertices on a circle ...
        let n = 3 + (seed % 12) as usize;
        let mut angles: Vec<f64> = (0..n).map(|_| rng.random_range(0.0..std::f64::consts::TAU)).collect();
        angles.sort_by(f64::total_cmp);
        let radius = rng.random_range(1.0..30.0);
        let convex = vec![Polygon {
            exterior: angles.iter().map(|&a| DVec2::from_angle(a) * radius).collect(),
            holes: vec![],
        }];
        check_erosion(&convex, eps, &mut rng);
        // ... and every level of every block (unions with shared walls).
        for block in merge_blocks(&scene.buildings) {
            for level in &block.levels {
                check_erosion(&level.area, eps, &mut rng);
            }
        }
    }

    #[test]
    fn merge_builds_the_height_field(seed in any::<u64>()) {
        let scene = scene(seed);
        let buildings = &scene.buildings;
        let blocks = merge_blocks(buildings);
        let members: Vec<Vec<usize>> = blocks.iter().map(|b| b.members.clone()).collect();
        prop_assert_eq!(&members, &scene.expected_blocks);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xb10c);
        for block in &blocks {
            let mut heights: Vec<f64> = block.members.iter().map(|&i| buildings[i].height).collect();
            heights.sort_by(f64::total_cmp);
            heights.dedup();
            let level_heights: Vec<f64> = block.levels.iter().map(|l| l.height).collect();
            prop_assert_eq!(level_heights, heights);
            let footprints: Vec<Polygon> = block
                .members
                .iter()
                .flat_map(|&i| buildings[i].footprint.iter().cloned())
                .collect();
            for level in &block.levels {
                assert_model_polygons(&level.area);
            }
            // Every member footprint lies inside level 0.
            let ground = &block.levels[0].area;
            for p in edge_points(&footprints, 4) {
                prop_assert!(point_in_multipolygon(p, ground) || boundary_distance(p, ground) < 1e-6);
            }
            // Levels nest.
            for pair in block.levels.windows(2) {
                for p in edge_points(&pair[1].area, 4) {
                    prop_assert!(
                        point_in_multipolygon(p, &pair[0].area)
                            || boundary_distance(p, &pair[0].area) < 1e-6
                    );
                }
                prop_assert!(multipolygon_area(&pair[1].area) <= multipolygon_area(&pair[0].area) + 1e-9);
            }
            // Level j is exactly the union of the members at least H_j high.
            for p in box_points(&mut rng, &footprints, 300) {
                if boundary_distance(p, &footprints) < 1e-6 {
                    continue;
                }
                for level in &block.levels {
                    let expected = block.members.iter().any(|&i| {
                        buildings[i].height >= level.height
                            && point_in_multipolygon(p, &buildings[i].footprint)
                    });
                    prop_assert_eq!(point_in_multipolygon(p, &level.area), expected);
                }
            }
        }
    }
}

#[test]
fn merge_skips_lifted_parts_and_is_deterministic() {
    let mut scene = scene(7);
    let first = merge_blocks(&scene.buildings);
    let again = merge_blocks(&scene.buildings);
    assert_eq!(format!("{first:?}"), format!("{again:?}"));
    for b in &mut scene.buildings {
        b.occludes = false;
    }
    assert!(merge_blocks(&scene.buildings).is_empty());
}
