//! A unit's visible set is a function of its points and the scene only:
//! `Solver::solve_run` over an edge's samples gives the union of what each
//! sample sees alone, whatever the solver solved before, and a bake gives
//! the same sets for any thread count.

use citypvs::generate::{GenerateParams, generate_geojson};
use citypvs::input::{InputOptions, read_city_bytes};
use citypvs::prepare::{PrepareParams, Scene, prepare};
use citypvs::visibility::bitset::ObjectSet;
use citypvs::visibility::index::SceneIndex;
use citypvs::visibility::samples::MeshTopology;
use citypvs::visibility::solver::Solver;
use citypvs::visibility::{VisibilityParams, compute_pvs};
use glam::DVec2;

fn scene(buildings: usize, seed: u64) -> Scene {
    let geojson = generate_geojson(&GenerateParams { buildings, seed });
    let city = read_city_bytes(
        geojson.as_bytes(),
        &format!("generated-{seed}"),
        &InputOptions::default(),
    )
    .expect("read generated city");
    prepare(city, &PrepareParams::default()).expect("prepare")
}

#[test]
fn a_run_sees_the_union_of_its_samples_whatever_came_before() {
    let scene = scene(120, 4);
    let params = VisibilityParams::for_eps(scene.eps);
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = scene.city.buildings.len();
    let spacing = 2.0 * scene.eps;
    // Every 15th edge, so the test stays short but spans the whole city.
    let edges: Vec<usize> = (0..topo.edges.len()).step_by(15).collect();
    assert!(edges.len() > 10);
    let runs: Vec<Vec<DVec2>> = edges
        .iter()
        .map(|&e| topo.edge_interior_samples(e, spacing))
        .collect();
    // Each sample alone, each with a fresh solver.
    let alone: Vec<ObjectSet> = runs
        .iter()
        .map(|points| {
            let mut set = ObjectSet::new(n);
            for &p in points {
                let mut solver = Solver::new(&index, params.eye_height, params.near_field);
                let mut own = ObjectSet::new(n);
                solver.solve(p, &mut own);
                set.union_with(&own);
            }
            set
        })
        .collect();
    // Whole runs, one solver reused forwards, and another one backwards.
    let mut forwards = Solver::new(&index, params.eye_height, params.near_field);
    let mut backwards = Solver::new(&index, params.eye_height, params.near_field);
    let fwd: Vec<ObjectSet> = runs
        .iter()
        .map(|points| {
            let mut set = ObjectSet::new(n);
            forwards.solve_run(points, &mut set);
            set
        })
        .collect();
    let mut bwd: Vec<ObjectSet> = runs
        .iter()
        .rev()
        .map(|points| {
            let mut set = ObjectSet::new(n);
            backwards.solve_run(points, &mut set);
            set
        })
        .collect();
    bwd.reverse();
    let mut seen = 0;
    for (i, e) in edges.iter().enumerate() {
        assert_eq!(
            fwd[i], alone[i],
            "edge {e}: run differs from its samples alone"
        );
        assert_eq!(
            bwd[i], alone[i],
            "edge {e}: depends on what was solved before"
        );
        seen += alone[i].count();
    }
    assert!(seen > 0, "the runs see something");
}

#[test]
fn a_run_starting_with_objects_already_in_the_set_adds_the_same_others() {
    let scene = scene(80, 9);
    let params = VisibilityParams::for_eps(scene.eps);
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = scene.city.buildings.len();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    for e in (0..topo.edges.len()).step_by(11) {
        let points = topo.edge_interior_samples(e, 2.0 * scene.eps);
        let mut fresh = ObjectSet::new(n);
        solver.solve_run(&points, &mut fresh);
        // Start from every third object already present.
        let mut seeded = ObjectSet::new(n);
        for o in (0..n).step_by(3) {
            seeded.insert(o);
        }
        solver.solve_run(&points, &mut seeded);
        let mut expected = fresh.clone();
        for o in (0..n).step_by(3) {
            expected.insert(o);
        }
        assert_eq!(seeded, expected, "edge {e}");
    }
}

#[test]
fn bake_sets_do_not_depend_on_the_thread_count() {
    let scene = scene(100, 2);
    let params = VisibilityParams::for_eps(scene.eps);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| compute_pvs(&scene, &params, &|_| {}).unwrap().visible)
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert!(one.iter().any(|v| !v.is_empty()));
}
