//! Hand-made checks of the view cells.

use crate::common::{block, rect, ring_building};
use citypvs::cells::{CellParams, triangulate};
use citypvs::geometry::merge_blocks;
use citypvs::model::{Polygon, point_in_multipolygon};
use glam::DVec2;

fn area(t: &[DVec2; 3]) -> f64 {
    0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0])
}

#[test]
fn cells_cover_the_box_minus_footprints_and_courtyards_get_cells() {
    let buildings = vec![
        ring_building("ring", DVec2::ZERO, 20.0, 8.0, 10.0),
        block("house", 40.0, -5.0, 50.0, 5.0, 6.0),
    ];
    let blocks = merge_blocks(&buildings);
    let params = CellParams {
        margin: 10.0,
        max_edge: 7.0,
        region: None,
        min_gap: 0.0,
    };
    let cells = triangulate(&blocks, &params).unwrap();
    let region_area = 90.0 * 60.0; // box (-20..50, -20..20) grown by 10
    let footprints = 40.0 * 40.0 - 16.0 * 16.0 + 100.0;
    let total: f64 = cells.triangles.iter().map(area).sum();
    assert!((total - (region_area - footprints)).abs() < 1e-6 * region_area);
    assert!(cells.triangles.iter().all(|t| area(t) > 0.0));
    let longest = cells
        .triangles
        .iter()
        .flat_map(|t| (0..3).map(move |i| t[i].distance(t[(i + 1) % 3])))
        .fold(0.0, f64::max);
    assert!(longest <= 7.0 + 1e-9, "{longest}");
    let footprints: Vec<Polygon> = buildings.iter().flat_map(|b| b.footprint.clone()).collect();
    for t in &cells.triangles {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        assert!(!point_in_multipolygon(c, &footprints));
    }
    // Courtyard cells.
    let courtyard: f64 = cells
        .triangles
        .iter()
        .filter(|t| {
            let c = (t[0] + t[1] + t[2]) / 3.0;
            c.x.abs() < 8.0 && c.y.abs() < 8.0
        })
        .map(area)
        .sum();
    assert!((courtyard - 256.0).abs() < 1e-6);
    // Deterministic.
    let again = triangulate(&blocks, &params).unwrap();
    assert_eq!(cells.triangles, again.triangles);
}

#[test]
fn a_given_region_clips_the_footprints() {
    let buildings = vec![block("a", 0.0, 0.0, 10.0, 10.0, 10.0)];
    let blocks = merge_blocks(&buildings);
    let mut region = rect(5.0, 5.0, 25.0, 25.0);
    region.reverse(); // clockwise on purpose: it must be accepted
    let params = CellParams {
        margin: 0.0,
        max_edge: 30.0,
        region: Some(Polygon {
            exterior: region,
            holes: vec![],
        }),
        min_gap: 0.0,
    };
    let cells = triangulate(&blocks, &params).unwrap();
    let total: f64 = cells.triangles.iter().map(area).sum();
    assert!((total - (400.0 - 25.0)).abs() < 1e-9);
}

#[test]
fn degenerate_input_is_an_error() {
    assert!(triangulate(&[], &CellParams::default()).is_err());
    let blocks = merge_blocks(&[block("a", 0.0, 0.0, 10.0, 10.0, 10.0)]);
    let bad_edge = CellParams {
        max_edge: 0.0,
        ..CellParams::default()
    };
    assert!(triangulate(&blocks, &bad_edge).is_err());
    let covered = CellParams {
        region: Some(Polygon {
            exterior: rect(1.0, 1.0, 9.0, 9.0),
            holes: vec![],
        }),
        ..CellParams::default()
    };
    assert!(triangulate(&blocks, &covered).is_err());
    let flat = CellParams {
        region: Some(Polygon {
            exterior: vec![DVec2::ZERO, DVec2::X, DVec2::new(2.0, 0.0)],
            holes: vec![],
        }),
        ..CellParams::default()
    };
    assert!(triangulate(&blocks, &flat).is_err());
    let huge = CellParams {
        margin: 1e7,
        max_edge: 1.0,
        region: None,
        min_gap: 0.0,
    };
    assert!(triangulate(&blocks, &huge).is_err());
}
