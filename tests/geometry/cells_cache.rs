//! The geometry cache: preparing an edited city with the shrunk levels and
//! opened tiles of the unedited one taken from a memo gives, bit for bit,
//! the occluders and cells of preparing it from nothing, whatever the edit
//! (a building moved, removed, copied elsewhere or raised), while the memo
//! really answers for what the edit left alone.

use std::collections::HashMap;

use citypvs::geometry::memo::ShapeMemo;
use citypvs::model::Building;
use citypvs::prepare::{Scene, prepare, prepare_with};
use glam::DVec2;
use proptest::prelude::*;

use super::common::{generated_buildings, metric_city};

/// Every coordinate of the occluders and cells, as bits, with heights and
/// ring structure.
fn fingerprint(scene: &Scene) -> Vec<u64> {
    let mut out = Vec::new();
    for o in &scene.occluders {
        out.extend([o.block as u64, o.level as u64, o.height.to_bits()]);
        for p in &o.shape {
            out.push(p.holes.len() as u64);
            for ring in std::iter::once(&p.exterior).chain(&p.holes) {
                out.push(ring.len() as u64);
                out.extend(ring.iter().flat_map(|v| [v.x.to_bits(), v.y.to_bits()]));
            }
        }
    }
    out.push(u64::MAX);
    for t in &scene.cells.triangles {
        out.extend(t.iter().flat_map(|v| [v.x.to_bits(), v.y.to_bits()]));
    }
    out
}

fn edited(
    mut buildings: Vec<Building>,
    kind: usize,
    pick: usize,
    dx: f64,
    dy: f64,
) -> Vec<Building> {
    let i = pick % buildings.len();
    let shift = |b: &mut Building| {
        for p in &mut b.footprint {
            for ring in std::iter::once(&mut p.exterior).chain(&mut p.holes) {
                ring.iter_mut().for_each(|v| *v += DVec2::new(dx, dy));
            }
        }
    };
    match kind {
        0 => shift(&mut buildings[i]),
        1 => {
            buildings.remove(i);
        }
        2 => {
            let mut copy = buildings[i].clone();
            copy.id = "copy".into();
            shift(&mut copy);
            buildings.push(copy);
        }
        _ => buildings[i].height += 7.0,
    }
    buildings
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn a_cached_preparation_is_the_preparation(
        seed in 0u64..1000,
        kind in 0usize..4,
        pick in 0usize..1000,
        dx in -6.0f64..6.0,
        dy in -6.0f64..6.0,
    ) {
        let settings = citypvs::Settings::default();
        let base = generated_buildings(120, seed, citypvs::generate::Style::Default);
        let first = ShapeMemo::with(HashMap::new());
        let base_scene = prepare_with(metric_city(base.clone()), &settings, &first).unwrap();
        prop_assert_eq!(first.stats().taken, 0);
        let earlier: HashMap<_, _> = first
            .into_results()
            .iter()
            .map(|(k, s)| (*k, s.clone()))
            .collect();
        // The same city again: everything is taken, nothing computed.
        let again = ShapeMemo::with(earlier.clone());
        let same = prepare_with(metric_city(base.clone()), &settings, &again).unwrap();
        prop_assert_eq!(again.stats().computed, 0);
        prop_assert!(fingerprint(&same) == fingerprint(&base_scene));

        let edit = edited(base, kind, pick, dx, dy);
        let memo = ShapeMemo::with(earlier);
        let cached = prepare_with(metric_city(edit.clone()), &settings, &memo).unwrap();
        let fresh = prepare(metric_city(edit), &settings).unwrap();
        prop_assert!(fingerprint(&cached) == fingerprint(&fresh), "edit {} of building {}", kind, pick);
        let stats = memo.stats();
        prop_assert!(stats.taken > 2 * stats.computed, "{:?}", stats);
    }
}
