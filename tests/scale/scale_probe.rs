//! The incremental bake's probe (condition 3 of docs/DESIGN.md,
//! "Incremental bakes") tests a changed building by the bake's own test of
//! a building outside the window: its footprint's hull, at the distance it
//! is queued at, with the needed slope raised by a rounding margin. So
//! "hidden" from the probe is "hidden" in the bake, and the probe says
//! "not hidden" only where the bake sees the building (or, within the
//! margin, ties with it).

use citypvs::model::Rect;
use citypvs::visibility::bitset::ObjectSet;
use citypvs::visibility::index::SceneIndex;
use citypvs::visibility::samples::MeshTopology;
use citypvs::visibility::solver::Solver;
use glam::DVec2;

#[test]
fn the_probe_says_hidden_where_the_bake_does_on_kotka() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kotka.geojson");
    let city = citypvs::input::read_city(&path, &citypvs::input::InputOptions::default())
        .expect("read Kotka");
    let scene = citypvs::prepare::prepare(city, &citypvs::Settings::default()).expect("prepare");
    let params = &scene.settings;
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = index.objects.len();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    // The incremental bake probes only buildings outside every window of
    // the cell's samples (condition 2).
    let reach = params.near_field + 2.0 * params.pixel;
    let (mut hidden, mut seen, mut ties) = (0, 0, 0);
    let step = (topo.vertices.len() / 120).max(1);
    for (k, &v) in topo.vertices.iter().step_by(step).enumerate() {
        let window = Rect {
            min: v - DVec2::splat(reach),
            max: v + DVec2::splat(reach),
        };
        let mut visible = ObjectSet::new(n);
        solver.solve_run(&[v], &mut visible);
        for j in 0..60 {
            let o = ((k * 7919 + j * 104_729) % n) as u32;
            if index.objects[o as usize].rect.intersects(&window) {
                continue;
            }
            let probe = solver.probe_hidden(v, &[o]);
            let bake = !visible.contains(o as usize);
            assert!(
                !probe || bake,
                "point {v:?}, building {o}: the probe says hidden, the bake sees it"
            );
            match (probe, bake) {
                (true, _) => hidden += 1,
                (false, false) => seen += 1,
                (false, true) => ties += 1,
            }
        }
    }
    assert!(hidden > 1000 && seen > 100, "{hidden} hidden, {seen} seen");
    // Only a tie within the margin may make the probe say "not hidden"
    // where the bake hides the building.
    assert!(
        ties * 1000 <= hidden,
        "{ties} buildings the bake hides were not shown hidden by the probe ({hidden} were)"
    );
}
