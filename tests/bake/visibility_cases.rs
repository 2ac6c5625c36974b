//! Hand-checked visibility cases whose answers are known.

use crate::common::*;
use citypvs::visibility::VisibilityEngine;
use glam::DVec2;

fn pvs_ids(scene: &citypvs::prepare::Scene) -> Vec<String> {
    VisibilityEngine::new(scene)
        .unwrap()
        .solve_cell(0)
        .iter()
        .map(|&i| scene.city.buildings[i as usize].id.clone())
        .collect()
}

fn cell() -> [DVec2; 3] {
    cell_at(DVec2::ZERO, 3.0)
}

#[test]
fn tall_wall_hides_low_house_behind_it() {
    let scene = hand_scene(
        vec![
            block("wall", -40.0, 10.0, 40.0, 14.0, 20.0),
            block("house", -5.0, 30.0, 5.0, 40.0, 8.0),
        ],
        vec![cell()],
        1.0,
    );
    assert_eq!(pvs_ids(&scene), vec!["wall"]);
}

#[test]
fn house_seen_over_a_lower_one() {
    let scene = hand_scene(
        vec![
            block("low", -40.0, 10.0, 40.0, 14.0, 4.0),
            block("tall", -5.0, 30.0, 5.0, 40.0, 25.0),
        ],
        vec![cell()],
        1.0,
    );
    assert_eq!(pvs_ids(&scene), vec!["low", "tall"]);
}

#[test]
fn two_walls_hide_together_what_neither_hides_alone() {
    // Wall A in front covers x < 2, wall B behind it covers x > -2: from every
    // point of the cell, each sight line to the house passes through A or B,
    // but neither alone hides the house from the whole cell.
    let a = block("A", -60.0, 10.0, 2.0, 13.0, 30.0);
    let b = block("B", -2.0, 16.0, 60.0, 19.0, 30.0);
    let house = block("house", -4.0, 40.0, 4.0, 48.0, 10.0);
    let together = hand_scene(vec![a.clone(), b.clone(), house.clone()], vec![cell()], 1.0);
    assert_eq!(pvs_ids(&together), vec!["A", "B"]);
    let only_a = hand_scene(vec![a, house.clone()], vec![cell()], 1.0);
    assert!(pvs_ids(&only_a).contains(&"house".to_string()));
    let only_b = hand_scene(vec![b, house], vec![cell()], 1.0);
    assert!(pvs_ids(&only_b).contains(&"house".to_string()));
}

#[test]
fn courtyard_building_hides_its_outside_and_inside() {
    let ring = ring_building("ring", DVec2::new(0.0, 0.0), 30.0, 12.0, 15.0);
    let outside_house = block("outside", 50.0, -5.0, 60.0, 5.0, 8.0);
    // A cell in the courtyard sees the ring but not the low house outside.
    let scene = hand_scene(vec![ring.clone(), outside_house.clone()], vec![cell()], 1.0);
    assert_eq!(pvs_ids(&scene), vec!["ring"]);
    // A cell outside sees the ring and the house beside it, not a low shed in the courtyard.
    let shed = block("shed", -3.0, -3.0, 3.0, 3.0, 4.0);
    let scene = hand_scene(
        vec![ring, outside_house, shed],
        vec![cell_at(DVec2::new(45.0, 0.0), 3.0)],
        1.0,
    );
    assert_eq!(pvs_ids(&scene), vec!["ring", "outside"]);
}

#[test]
fn narrow_gap_keeps_what_is_behind_it() {
    // Two tall walls with a 1 m gap (narrower than 2 * eps) straight ahead;
    // a house behind the gap is visible through it from the cell.
    let scene = hand_scene(
        vec![
            block("left", -60.0, 10.0, -0.5, 14.0, 30.0),
            block("right", 0.5, 10.0, 60.0, 14.0, 30.0),
            block("house", -2.0, 40.0, 2.0, 44.0, 6.0),
        ],
        vec![cell()],
        1.0,
    );
    assert_eq!(pvs_ids(&scene), vec!["left", "right", "house"]);
}

#[test]
fn wide_gap_keeps_and_solid_block_culls() {
    let scene = hand_scene(
        vec![
            block("left", -60.0, 10.0, -6.0, 14.0, 30.0),
            block("right", 6.0, 10.0, 60.0, 14.0, 30.0),
            block("through-gap", -2.0, 40.0, 2.0, 44.0, 6.0),
            block("behind-solid", 45.0, 40.0, 50.0, 44.0, 6.0),
        ],
        vec![cell()],
        1.0,
    );
    assert_eq!(pvs_ids(&scene), vec!["left", "right", "through-gap"]);
}

#[test]
fn far_buildings_behind_a_street_wall_are_culled_by_the_horizon() {
    // Long street walls on both sides of a cell; many houses far behind them
    // (beyond the first near-field window) are all hidden.
    let mut buildings = vec![
        block("north", -400.0, 8.0, 400.0, 20.0, 20.0),
        block("south", -400.0, -20.0, 400.0, -8.0, 20.0),
    ];
    for k in 0..20 {
        let x = -300.0 + 30.0 * k as f64;
        buildings.push(block(&format!("far{k}"), x, 100.0, x + 10.0, 110.0, 12.0));
        buildings.push(block(
            &format!("tower{k}"),
            x,
            -300.0,
            x + 10.0,
            -290.0,
            12.0,
        ));
    }
    let scene = hand_scene(buildings, vec![cell()], 1.0);
    assert_eq!(pvs_ids(&scene), vec!["north", "south"]);
}

#[test]
fn pixel_size_that_breaks_the_bound_is_refused() {
    let err = citypvs::Settings::new(citypvs::RawSettings {
        eps: Some(1.0),
        pixel: Some(1.5),
        ..Default::default()
    })
    .unwrap_err();
    assert_eq!(err.kind(), &citypvs::ErrorKind::Setting("pixel"));
    assert!(
        err.message().contains("pixel * sqrt(2) / 2 <= eps"),
        "{err}"
    );
}
