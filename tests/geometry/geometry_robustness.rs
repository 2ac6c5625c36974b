//! Broken and degenerate geometry never makes merge, erosion or
//! triangulation panic: they return a result or an error.

use citypvs::cells::{CellParams, triangulate, triangulate_exact};
use citypvs::geometry::{erode, merge_blocks, shrink_blocks};
use citypvs::model::{Building, Polygon};
use glam::DVec2;
use proptest::prelude::*;

fn building(ring: Vec<DVec2>, holes: Vec<Vec<DVec2>>, height: f64) -> Building {
    Building {
        id: "x".into(),
        footprint: vec![Polygon {
            exterior: ring,
            holes,
        }],
        height,
        occludes: true,
    }
}

fn run_all(buildings: &[Building]) {
    let blocks = merge_blocks(buildings);
    let _ = shrink_blocks(&blocks, 1.0);
    let _ = triangulate(&blocks, &CellParams::default());
    for b in buildings {
        let _ = erode(&b.footprint, 0.5);
    }
}

#[test]
fn degenerate_footprints_do_not_panic() {
    let p = |x: f64, y: f64| DVec2::new(x, y);
    let cases = vec![
        building(vec![], vec![], 10.0),
        building(vec![p(0.0, 0.0)], vec![], 10.0),
        building(vec![p(0.0, 0.0), p(1.0, 1.0)], vec![], 10.0),
        building(vec![p(0.0, 0.0), p(1.0, 1.0), p(2.0, 2.0)], vec![], 10.0),
        building(vec![p(0.0, 0.0), p(0.0, 0.0), p(0.0, 0.0)], vec![], 10.0),
        // Bow tie.
        building(
            vec![p(0.0, 0.0), p(10.0, 10.0), p(10.0, 0.0), p(0.0, 10.0)],
            vec![],
            10.0,
        ),
        // Clockwise exterior, counter-clockwise hole, hole outside.
        building(
            vec![p(0.0, 0.0), p(0.0, 10.0), p(10.0, 10.0), p(10.0, 0.0)],
            vec![vec![p(20.0, 20.0), p(25.0, 20.0), p(25.0, 25.0)]],
            10.0,
        ),
        building(
            vec![p(f64::NAN, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
            vec![],
            10.0,
        ),
        building(
            vec![p(f64::INFINITY, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
            vec![],
            10.0,
        ),
        building(
            vec![p(0.0, 0.0), p(1e-300, 0.0), p(0.0, 1e-300)],
            vec![],
            10.0,
        ),
        building(vec![p(0.0, 0.0), p(1e15, 0.0), p(0.0, 1e15)], vec![], 10.0),
        building(
            vec![p(0.0, 0.0), p(5.0, 0.0), p(5.0, 5.0)],
            vec![],
            f64::NAN,
        ),
    ];
    for case in &cases {
        run_all(std::slice::from_ref(case));
    }
    run_all(&cases);
    // Identical duplicates merge into one block with one level.
    let square = building(
        vec![p(0.0, 0.0), p(5.0, 0.0), p(5.0, 5.0), p(0.0, 5.0)],
        vec![],
        7.0,
    );
    let blocks = merge_blocks(&[square.clone(), square]);
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].members, vec![0, 1]);
    assert_eq!(blocks[0].levels.len(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_rings_do_not_panic(
        rings in prop::collection::vec(
            prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0), 0..9),
            1..6,
        ),
        eps in 0.0f64..5.0,
        max_edge in 1.0f64..40.0,
    ) {
        let buildings: Vec<Building> = rings
            .into_iter()
            .enumerate()
            .map(|(i, r)| building(r.into_iter().map(|(x, y)| DVec2::new(x, y)).collect(), vec![], 5.0 + i as f64))
            .collect();
        let blocks = merge_blocks(&buildings);
        let _ = shrink_blocks(&blocks, eps);
        let params = CellParams { margin: 10.0, max_edge, region: None, min_gap: 0.0 };
        if let Ok(cells) = triangulate_exact(&blocks, &params) {
            for t in &cells.triangles {
                prop_assert!((t[1] - t[0]).perp_dot(t[2] - t[0]) > 0.0);
                for i in 0..3 {
                    prop_assert!(t[i].distance(t[(i + 1) % 3]) <= max_edge + 1e-9);
                }
            }
        }
    }
}
