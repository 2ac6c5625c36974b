//! The engine refuses, before it allocates its occluder index, a scene
//! whose occluders would be cut into more points than the index can number,
//! and says so with a limit error naming the pieces.

use citypvs::ErrorKind;
use citypvs::geometry::Occluder;
use citypvs::model::Polygon;
use citypvs::visibility::VisibilityEngine;
use citypvs::visibility::index::{MAX_INDEX_POINTS, SceneIndex};
use glam::DVec2;

/// A level whose one ring zigzags `sides` times across `width` metres.
fn zigzag(sides: usize, width: f64) -> Occluder {
    let exterior = (0..sides)
        .map(|i| DVec2::new(if i % 2 == 0 { 0.0 } else { width }, i as f64))
        .collect();
    Occluder {
        block: 0,
        level: 0,
        height: 10.0,
        shape: vec![Polygon {
            exterior,
            holes: vec![],
        }],
    }
}

#[test]
fn an_index_of_too_many_points_is_refused_before_it_is_built() {
    let mut scene = crate::common::generated_scene(30, 1);
    let fits = SceneIndex::points_needed(&scene.occluders);
    assert!(fits > 0 && fits < MAX_INDEX_POINTS);
    assert!(VisibilityEngine::new(&scene).is_ok());
    // 15,000 sides of 900 km, each cut into 150,000 pieces of 6 m: 2.25e9
    // points, counted in a moment and never cut.
    scene.occluders.push(zigzag(15_000, 900_000.0));
    let needed = SceneIndex::points_needed(&scene.occluders);
    assert!(needed > MAX_INDEX_POINTS, "{needed}");
    let Err(err) = VisibilityEngine::new(&scene) else {
        panic!("an index of {needed} points was built");
    };
    assert_eq!(err.kind(), &ErrorKind::Limit("occluder pieces"));
    assert!(err.to_string().contains(&needed.to_string()), "{err}");
}
