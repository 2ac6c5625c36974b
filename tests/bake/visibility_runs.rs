//! A unit's visible set is a function of its points and the scene only:
//! `Solver::solve_run` gives the same set whatever the solver solved
//! before, it keeps everything its first sample sees, a run started from a
//! set adds to it just what it finds from nothing (so an edge seeded with
//! its corners' sets leaves every cell's PVS as it was), an edge started
//! from the chains a corner carried on gives the set it gives from none,
//! and a bake gives the same sets for any thread count.

use citypvs::visibility::bitset::ObjectSet;
use citypvs::visibility::index::SceneIndex;
use citypvs::visibility::samples::MeshTopology;
use citypvs::visibility::solver::Solver;
use glam::DVec2;

/// A generated city's scene with its index and mesh topology.
fn indexed_city(
    buildings: usize,
    seed: u64,
) -> (citypvs::prepare::Scene, SceneIndex, MeshTopology) {
    let scene = crate::common::generated_scene(buildings, seed);
    let index = SceneIndex::build(
        &scene.city.buildings,
        &scene.occluders,
        scene.settings.pixel,
    );
    let topo = MeshTopology::of(&scene.cells.triangles);
    (scene, index, topo)
}

#[test]
fn a_run_does_not_depend_on_what_the_solver_solved_before() {
    let (scene, index, topo) = indexed_city(120, 4);
    let params = &scene.settings;
    let n = scene.city.buildings.len();
    let spacing = scene.settings.sample_spacing();
    // Every 9th edge and every 9th vertex, so the test stays short but
    // spans the whole city.
    let mut runs: Vec<Vec<DVec2>> = (0..topo.edges.len())
        .step_by(9)
        .map(|e| topo.edge_interior_samples(e, spacing))
        .collect();
    runs.extend(topo.vertices.iter().step_by(9).map(|&v| vec![v]));
    assert!(runs.len() > 20);
    // Each run with a fresh solver.
    let fresh: Vec<ObjectSet> = runs
        .iter()
        .map(|points| {
            let mut solver = Solver::new(&index, params.eye_height, params.near_field);
            let mut set = ObjectSet::new(n);
            solver.solve_run(points, &mut set);
            set
        })
        .collect();
    // One solver reused forwards, and another one backwards.
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
    for i in 0..runs.len() {
        assert_eq!(
            fwd[i], fresh[i],
            "run {i}: depends on what was solved before"
        );
        assert_eq!(
            bwd[i], fresh[i],
            "run {i}: depends on what was solved before"
        );
    }
    assert!(
        fresh.iter().any(|s| s.count() > 0),
        "the runs see something"
    );
}

#[test]
fn an_edge_started_from_a_corners_carried_chains_gives_the_same_set() {
    let (scene, index, topo) = indexed_city(120, 4);
    let params = &scene.settings;
    let n = scene.city.buildings.len();
    let spacing = scene.settings.sample_spacing();
    let solve = |carried: Option<&[u64]>, points: &[DVec2]| {
        let mut solver = Solver::new(&index, params.eye_height, params.near_field);
        if let Some(tags) = carried {
            solver.set_carried(tags);
        }
        let mut set = ObjectSet::new(n);
        solver.solve_run(points, &mut set);
        (set, solver.carried().to_vec())
    };
    let mut checked = 0;
    for e in (0..topo.edges.len()).step_by(7) {
        let points = topo.edge_interior_samples(e, spacing);
        if points.is_empty() {
            continue;
        }
        let [a, b] = topo.edges[e];
        let (_, from_a) = solve(None, &[topo.vertices[a as usize]]);
        let (_, from_b) = solve(None, &[topo.vertices[b as usize]]);
        assert!(!from_a.is_empty(), "edge {e}: the corner carries chains");
        let (fresh, _) = solve(None, &points);
        // From its first corner (as the engine does), and from the other
        // end, whose chains suit the first sample far less.
        assert_eq!(solve(Some(&from_a), &points).0, fresh, "edge {e}");
        assert_eq!(solve(Some(&from_b), &points).0, fresh, "edge {e}");
        checked += 1;
    }
    assert!(checked > 20, "{checked}");
}

#[test]
fn a_run_keeps_everything_its_first_sample_sees() {
    // The first sample of a run starts from the same empty set as the
    // sample alone, so it gives exactly the same verdicts.
    let (scene, index, topo) = indexed_city(80, 9);
    let params = &scene.settings;
    let n = scene.city.buildings.len();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    for e in (0..topo.edges.len()).step_by(11) {
        let points = topo.edge_interior_samples(e, scene.settings.sample_spacing());
        let Some(&first) = points.first() else {
            continue;
        };
        let mut alone = ObjectSet::new(n);
        solver.solve(first, &mut alone);
        let mut run = ObjectSet::new(n);
        solver.solve_run(&points, &mut run);
        let mut union = run.clone();
        union.union_with(&alone);
        assert_eq!(
            union, run,
            "edge {e}: the run lost what its first sample sees"
        );
    }
}

#[test]
fn bake_sets_do_not_depend_on_the_thread_count() {
    let scene = crate::common::generated_scene(100, 2);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                citypvs::visibility::VisibilityEngine::new(&scene)
                    .unwrap()
                    .solve_all(&|_| {})
                    .unwrap()
            })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    // More workers than cores: the cells of a chunk are shared out a few at
    // a time between three solvers.
    assert_eq!(one, run(3));
    assert!(one.iter().any(|v| !v.is_empty()));
}

#[test]
fn a_run_started_from_a_set_adds_what_it_finds_from_nothing() {
    let (scene, index, topo) = indexed_city(120, 6);
    let params = &scene.settings;
    let n = scene.city.buildings.len();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    let solve = |solver: &mut Solver, points: &[DVec2], seed: &ObjectSet| {
        let mut set = seed.clone();
        solver.solve_run(points, &mut set);
        set
    };
    let empty = ObjectSet::new(n);
    // Every third object: a seed that is no one's visible set.
    let mut thirds = ObjectSet::new(n);
    (0..n).step_by(3).for_each(|o| thirds.insert(o));
    let mut checked = 0;
    for e in (0..topo.edges.len()).step_by(7) {
        let points = topo.edge_interior_samples(e, params.sample_spacing());
        if points.is_empty() {
            continue;
        }
        let [a, b] = topo.edges[e];
        let mut ends = solve(&mut solver, &[topo.vertices[a as usize]], &empty);
        ends.union_with(&solve(&mut solver, &[topo.vertices[b as usize]], &empty));
        let alone = solve(&mut solver, &points, &empty);
        for seed in [&ends, &thirds] {
            let mut expected = alone.clone();
            expected.union_with(seed);
            assert_eq!(
                solve(&mut solver, &points, seed),
                expected,
                "edge {e}: a seeded run is not the seed plus the run from nothing"
            );
        }
        assert!(
            alone.count() > 0 && ends.count() > 0,
            "edge {e} sees something"
        );
        checked += 1;
    }
    assert!(checked > 20, "{checked} edges checked");
}

#[test]
fn cells_are_the_union_of_their_units_solved_from_nothing() {
    // What the bake computes (edges seeded with their corners' sets, in
    // chunks) and one cell at a time, against the definition: the union of
    // the six units' sets, each solved from an empty set.
    let (scene, index, topo) = indexed_city(100, 8);
    let params = &scene.settings;
    let n = scene.city.buildings.len();
    let engine = citypvs::visibility::VisibilityEngine::new(&scene).unwrap();
    let all = engine.solve_all(&|_| {}).unwrap();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    for cell in (0..topo.cell_vertices.len()).step_by(5) {
        let mut expected = ObjectSet::new(n);
        for &v in &topo.cell_vertices[cell] {
            solver.solve_run(&[topo.vertices[v as usize]], &mut expected);
        }
        for &e in &topo.cell_edges[cell] {
            let mut set = ObjectSet::new(n);
            solver.solve_run(
                &topo.edge_interior_samples(e as usize, params.sample_spacing()),
                &mut set,
            );
            expected.union_with(&set);
        }
        assert_eq!(all[cell], expected.to_vec(), "cell {cell} (bake)");
        assert_eq!(
            engine.solve_cell(cell),
            expected.to_vec(),
            "cell {cell} (alone)"
        );
    }
}
