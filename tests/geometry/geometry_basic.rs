//! Hand-made checks of merging and erosion with known answers.

use crate::common::{block, rect, ring_building};
use citypvs::geometry::{EROSION_SAFETY_MARGIN, erode, merge_blocks, shrink_blocks};
use citypvs::model::{
    Building, Polygon, distance_to_segment, multipolygon_area, point_in_multipolygon,
    polygon_edges, ring_signed_area2,
};
use glam::DVec2;

fn boundary_distance(p: DVec2, mp: &[Polygon]) -> f64 {
    mp.iter()
        .flat_map(polygon_edges)
        .map(|(a, b)| distance_to_segment(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn touching_buildings_form_one_block_with_nested_levels() {
    let buildings = vec![
        block("low", 0.0, 0.0, 10.0, 10.0, 10.0),
        block("apart", 30.0, 0.0, 40.0, 10.0, 5.0),
        block("high", 10.0, 0.0, 20.0, 10.0, 20.0),
        block("corner", 20.0, 10.0, 25.0, 15.0, 10.0),
    ];
    let blocks = merge_blocks(&buildings);
    assert_eq!(blocks.len(), 2);
    assert_eq!(blocks[0].members, vec![0, 2, 3]);
    assert_eq!(blocks[1].members, vec![1]);
    let heights: Vec<f64> = blocks[0].levels.iter().map(|l| l.height).collect();
    assert_eq!(heights, vec![10.0, 20.0]);
    // Level 0: the shared wall is dissolved; the corner touches at a point.
    let ground = &blocks[0].levels[0].area;
    assert!((multipolygon_area(ground) - 225.0).abs() < 1e-6);
    assert!(ground.iter().all(|p| p.holes.is_empty()));
    assert!(
        ground
            .iter()
            .any(|p| p.exterior.len() == 4 && (ring_signed_area2(&p.exterior) - 400.0).abs() < 1e-6)
    );
    assert!((multipolygon_area(&blocks[0].levels[1].area) - 100.0).abs() < 1e-6);
}

#[test]
fn gaps_stay_open_and_lifted_parts_do_not_occlude() {
    let mut lifted = block("lifted", 10.0, 0.0, 20.0, 10.0, 30.0);
    lifted.occludes = false;
    let buildings = vec![
        block("a", 0.0, 0.0, 10.0, 10.0, 10.0),
        block("b", 10.001, 0.0, 20.0, 10.0, 10.0),
        lifted,
    ];
    let blocks = merge_blocks(&buildings);
    assert_eq!(blocks.len(), 2);
    assert_eq!(blocks[0].members, vec![0]);
    assert_eq!(blocks[1].members, vec![1]);
}

#[test]
fn erosion_of_a_square_is_the_inner_square() {
    let square = vec![Polygon {
        exterior: rect(0.0, 0.0, 10.0, 10.0),
        holes: vec![],
    }];
    let eroded = erode(&square, 1.0);
    let side = 8.0 - 2.0 * EROSION_SAFETY_MARGIN;
    assert!((multipolygon_area(&eroded) - side * side).abs() < 1e-4);
    for p in eroded.iter().flat_map(|p| p.exterior.iter()) {
        assert!(boundary_distance(*p, &square) >= 1.0);
    }
    assert!(erode(&square, 4.9995).is_empty());
    assert!(erode(&square, 5.5).is_empty());
}

#[test]
fn erosion_keeps_clear_of_reflex_corners_and_courtyards() {
    let b = ring_building("ring", DVec2::ZERO, 20.0, 8.0, 10.0);
    let eroded = erode(&b.footprint, 2.0);
    assert_eq!(eroded.len(), 1);
    assert_eq!(eroded[0].holes.len(), 1);
    // The hole's corners are rounded by the erosion: the circumscribed
    // approximation stays at least eps from the courtyard's corners.
    for p in polygon_edges(&eroded[0])
        .flat_map(|(a, b)| (0..=10).map(move |k| a + (b - a) * (k as f64 / 10.0)))
    {
        assert!(
            point_in_multipolygon(p, &b.footprint) || boundary_distance(p, &b.footprint) < 1e-9
        );
        assert!(boundary_distance(p, &b.footprint) >= 2.0 - 1e-9, "{p}");
    }
    // Exact erosion area: 36^2 - (16 + 4)^2 + (4 - pi) * 2^2 corners. The
    // margin costs about 0.22 m2, the two-sided corner wedges 4 x 0.17 m2.
    let exact = 36.0f64 * 36.0 - 20.0 * 20.0 + (4.0 - std::f64::consts::PI) * 4.0;
    let got = multipolygon_area(&eroded);
    assert!(got < exact && got > exact - 1.0, "{got} vs {exact}");
}

#[test]
fn shrink_drops_thin_levels() {
    let buildings: Vec<Building> = vec![
        block("thin", 0.0, 0.0, 1.0, 30.0, 40.0),
        block("wide", 1.0, 0.0, 20.0, 30.0, 10.0),
    ];
    let blocks = merge_blocks(&buildings);
    assert_eq!(blocks.len(), 1);
    let occluders = shrink_blocks(&blocks, 1.0);
    // Level 0 (the whole block at 10 m) survives; the 1 m wide tower level does not.
    assert_eq!(occluders.len(), 1);
    assert_eq!(occluders[0].level, 0);
    assert_eq!(occluders[0].height, 10.0);
}

#[test]
fn same_blocks_occluders_and_cells_for_any_thread_count() {
    use citypvs::cells::{CellParams, triangulate};
    let buildings = crate::common::generated_buildings(300, 3, citypvs::generate::Style::Default);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let blocks = merge_blocks(&buildings);
                let occluders = shrink_blocks(&blocks, 1.0);
                let cells = triangulate(&blocks, &CellParams::default()).unwrap();
                format!("{blocks:?}{occluders:?}{:?}", cells.triangles)
            })
    };
    let one = run(1);
    assert_eq!(one, run(3));
    assert_eq!(one, run(8));
}
