//! Open-sided structures (`building=roof`, `building=carport`): PVS objects
//! that never occlude. A house right behind a canopy is seen under it.

use citypvs::input::{InputOptions, read_city, read_city_bytes};
use citypvs::prepare::{Scene, prepare};
use glam::DVec2;

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/input/canopy.geojson");

fn metric() -> InputOptions {
    InputOptions {
        metric: true,
        ..InputOptions::default()
    }
}

fn params() -> citypvs::Settings {
    citypvs::Settings::new(citypvs::RawSettings {
        margin: Some(20.0),
        max_cell_edge: Some(5.0),
        ..Default::default()
    })
    .unwrap()
}

/// Per cell centroid, the ids in its PVS.
fn pvs(scene: &Scene) -> Vec<(DVec2, Vec<String>)> {
    let visible = citypvs::visibility::VisibilityEngine::new(scene)
        .unwrap()
        .solve_all(&|_| {})
        .unwrap();
    scene
        .cells
        .triangles
        .iter()
        .zip(&visible)
        .map(|(t, v)| {
            let ids = v
                .iter()
                .map(|&i| scene.city.buildings[i as usize].id.clone())
                .collect();
            // In the input's coordinates (the local frame may be shifted).
            let (x, y) = scene.city.frame.to_input((t[0] + t[1] + t[2]) / 3.0);
            (DVec2::new(x, y), ids)
        })
        .collect()
}

fn in_front(c: DVec2) -> bool {
    c.x.abs() < 6.0 && (-12.0..-1.0).contains(&c.y)
}

#[test]
fn roof_and_carport_are_objects_but_not_occluders() {
    let city = read_city(std::path::Path::new(FIXTURE), &metric()).unwrap();
    let occludes: Vec<(&str, bool)> = city
        .buildings
        .iter()
        .map(|b| (b.id.as_str(), b.occludes))
        .collect();
    assert_eq!(
        occludes,
        vec![("canopy", false), ("carport", false), ("behind", true)]
    );
    let scene = prepare(city, &params()).unwrap();
    // Only the house is a block; cells run under the canopy.
    assert_eq!(scene.blocks.len(), 1);
    let under = pvs(&scene).iter().any(|(c, ids)| {
        c.x.abs() < 14.0 && (1.0..9.0).contains(&c.y) && ids.contains(&"canopy".to_string())
    });
    assert!(under, "no cell under the canopy");
    let front: Vec<_> = pvs(&scene)
        .into_iter()
        .filter(|(c, _)| in_front(*c))
        .collect();
    assert!(front.len() >= 4);
    for (c, ids) in &front {
        assert!(ids.contains(&"canopy".to_string()), "cell at {c}: {ids:?}");
        assert!(ids.contains(&"behind".to_string()), "cell at {c}: {ids:?}");
    }
}

#[test]
fn the_same_canopy_as_a_closed_building_hides_the_house() {
    let text = std::fs::read_to_string(FIXTURE)
        .unwrap()
        .replace("\"building\":\"roof\"", "\"building\":\"yes\"");
    let city = read_city_bytes(text.as_bytes(), "closed.geojson", &metric()).unwrap();
    assert!(city.buildings[0].occludes);
    let scene = prepare(city, &params()).unwrap();
    // Straight in front (the PVS may keep a little more near the corners).
    let front: Vec<_> = pvs(&scene)
        .into_iter()
        .filter(|(c, _)| c.x.abs() < 3.0 && (-8.0..-2.0).contains(&c.y))
        .collect();
    assert!(!front.is_empty());
    for (c, ids) in &front {
        assert!(!ids.contains(&"behind".to_string()), "cell at {c}: {ids:?}");
    }
}

#[test]
fn osm_style_part_tags_and_cityjson_installations_do_not_occlude() {
    let text = r#"{"type":"FeatureCollection","features":[
{"type":"Feature","id":"part","properties":{"building:part":"roof","height":5},"geometry":{"type":"Polygon","coordinates":[[[0,0],[4,0],[4,4],[0,4],[0,0]]]}},
{"type":"Feature","id":"house","properties":{"building":"house","height":5},"geometry":{"type":"Polygon","coordinates":[[[10,0],[14,0],[14,4],[10,4],[10,0]]]}}]}"#;
    let city = read_city_bytes(text.as_bytes(), "parts.geojson", &metric()).unwrap();
    let occludes: Vec<bool> = city.buildings.iter().map(|b| b.occludes).collect();
    assert_eq!(occludes, vec![false, true]);
}
