//! The solver's skips of what lies below the horizon (whole nodes of the
//! bucket hierarchy, buckets, chains re-checked when they leave the queue,
//! chains that cannot raise any bin) leave out only chains that cannot
//! raise the horizon: the visible sets are the same as when every chain
//! nearer than an item enters the horizon in full before the item is
//! tested (`Solver::set_skip_hidden(false)`).

use citypvs::prepare::Scene;
use citypvs::visibility::bitset::ObjectSet;
use citypvs::visibility::horizon::{Cover, covering_bins};
use citypvs::visibility::index::SceneIndex;
use citypvs::visibility::samples::MeshTopology;
use citypvs::visibility::solver::Solver;
use glam::DVec2;
use proptest::prelude::*;

/// Solve about `runs` units (edge runs and single vertices spread over the
/// city) with the skips on and off; panic on the first set that differs.
/// Returns the total size of the sets and the number of objects times the
/// number of units, so callers can check the sets are neither empty nor
/// everything.
fn compare(scene: &Scene, runs: usize) -> (usize, usize) {
    let params = &scene.settings;
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = scene.city.buildings.len();
    let spacing = params.sample_spacing();
    let edge_step = (topo.edges.len() / runs.max(1)).max(1);
    let vertex_step = (topo.vertices.len() / runs.max(1)).max(1);
    let mut units: Vec<Vec<DVec2>> = (0..topo.edges.len())
        .step_by(edge_step)
        .map(|e| topo.edge_interior_samples(e, spacing))
        .filter(|r| !r.is_empty())
        .collect();
    units.extend(topo.vertices.iter().step_by(vertex_step).map(|&v| vec![v]));
    let mut fast = Solver::new(&index, params.eye_height, params.near_field);
    let mut full = Solver::new(&index, params.eye_height, params.near_field);
    full.set_skip_hidden(false);
    let mut seen = 0;
    for (u, points) in units.iter().enumerate() {
        let mut a = ObjectSet::new(n);
        fast.solve_run(points, &mut a);
        let mut b = ObjectSet::new(n);
        full.solve_run(points, &mut b);
        assert_eq!(
            a.to_vec(),
            b.to_vec(),
            "unit {u} ({} points from {:?}): the skips changed the visible set",
            points.len(),
            points[0]
        );
        seen += a.count();
    }
    (seen, n * units.len())
}

#[test]
fn a_city_with_districts_far_apart_sees_the_same_with_and_without_skips() {
    // 400 buildings span several 256 m nodes of the bucket hierarchy, so
    // whole nodes are skipped from most samples.
    let (seen, all) = compare(&crate::common::generated_scene(400, 3), 60);
    assert!(seen > 0, "something is visible");
    assert!(
        seen * 4 < all,
        "most of the city is hidden: {seen} of {all}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    #[test]
    fn random_cities_see_the_same_with_and_without_skips(
        buildings in 30usize..160,
        seed in any::<u64>(),
    ) {
        let (seen, all) = compare(&crate::common::generated_scene(buildings, seed), 40);
        prop_assert!(seen > 0);
        prop_assert!(seen < all);
    }
}

/// The incremental bake's probe stops at the first ring whose chains
/// already hide a rectangle and reads only the chains that can raise the
/// rectangles' bins; with the skips off it sweeps every ring and adds every
/// chain. Its answers must be the same both ways. Returns how many probes
/// said hidden and how many not.
fn compare_probes(scene: &Scene, points: usize) -> (usize, usize) {
    let params = &scene.settings;
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let mut fast = Solver::new(&index, params.eye_height, params.near_field);
    let mut full = Solver::new(&index, params.eye_height, params.near_field);
    full.set_skip_hidden(false);
    let objects: Vec<u32> = (0..index.objects.len() as u32).collect();
    let step = (topo.vertices.len() / points.max(1)).max(1);
    let (mut hidden, mut seen) = (0, 0);
    for (k, &v) in topo.vertices.iter().step_by(step).enumerate() {
        // One object, and a few objects spread over the city, per point.
        let one = vec![objects[(k * 7) % objects.len()]];
        let some: Vec<_> = (0..4)
            .map(|j| objects[(k * 13 + j * 31) % objects.len()])
            .collect();
        for targets in [one, some] {
            let a = fast.probe_hidden(v, &targets);
            let b = full.probe_hidden(v, &targets);
            assert_eq!(
                a, b,
                "point {v:?}, targets {targets:?}: the probe's answers differ"
            );
            if a {
                hidden += 1;
            } else {
                seen += 1;
            }
        }
    }
    (hidden, seen)
}

#[test]
fn the_probe_answers_the_same_with_and_without_its_early_stop() {
    let (hidden, seen) = compare_probes(&crate::common::generated_scene(400, 3), 150);
    assert!(hidden > 20 && seen > 20, "{hidden} hidden and {seen} not");
}

/// Solving a unit for some objects only (at each point every other object
/// and every one seen at an earlier point counts as decided, and only the
/// horizon bins that cover the rest are read, as an incremental bake does)
/// gives each of them the verdict of a full solve of the unit. The objects
/// are clusters around one or two buildings, so from far away they cover a
/// narrow range of directions and from near a wide one, at times more than
/// half a turn.
#[test]
fn solving_for_some_objects_gives_them_the_verdicts_of_a_full_solve() {
    let scene = crate::common::generated_scene(400, 3);
    let params = &scene.settings;
    let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, params.pixel);
    let topo = MeshTopology::of(&scene.cells.triangles);
    let n = scene.city.buildings.len();
    let spacing = params.sample_spacing();
    let mut solver = Solver::new(&index, params.eye_height, params.near_field);
    let (mut restricted, mut seen, mut hidden) = (0, 0, 0);
    let step = (topo.edges.len() / 400).max(1);
    for (u, e) in (0..topo.edges.len()).step_by(step).enumerate() {
        let points = topo.edge_interior_samples(e, spacing);
        if points.is_empty() {
            continue;
        }
        let middle = |r: &citypvs::model::Rect| (r.min + r.max) * 0.5;
        // One cluster, or two apart (so the bins to read often reach
        // round more than half a turn).
        let centres = [(u * 37) % n, (u * 37 + 11 * u + 5) % n];
        let centres = &centres[..1 + u % 2];
        let list: Vec<u32> = (0..n as u32)
            .filter(|&o| {
                centres.iter().any(|&c| {
                    let centre = middle(&index.objects[c].rect);
                    middle(&index.objects[o as usize].rect).distance(centre) < 120.0
                })
            })
            .collect();
        // Point by point, as the incremental bake does: the objects seen
        // so far count as decided, and only the bins covering the others
        // are read.
        let mut part: Vec<u32> = Vec::new();
        for &p in &points {
            let todo: Vec<u32> = list.iter().copied().filter(|o| !part.contains(o)).collect();
            if todo.is_empty() {
                continue;
            }
            let interest =
                match covering_bins(p, todo.iter().map(|&o| &index.objects[o as usize].rect)) {
                    Cover::Bins(lo, hi) => Some((lo, hi)),
                    Cover::Nothing | Cover::Everything => None,
                };
            restricted += usize::from(interest.is_some());
            let mut set = ObjectSet::new(n);
            set.fill(n);
            for &o in &todo {
                set.remove(o as usize);
            }
            solver.solve_point_for(p, interest, &todo, &mut set);
            part.extend(todo.iter().copied().filter(|&o| set.contains(o as usize)));
        }
        let mut full = ObjectSet::new(n);
        solver.solve_run(&points, &mut full);
        for &o in &list {
            assert_eq!(
                part.contains(&o),
                full.contains(o as usize),
                "edge {e} ({} points from {:?}), object {o}: the verdicts differ",
                points.len(),
                points[0]
            );
            if full.contains(o as usize) {
                seen += 1;
            } else {
                hidden += 1;
            }
        }
    }
    assert!(
        restricted > 100,
        "only {restricted} samples were restricted"
    );
    assert!(seen > 50 && hidden > 50, "{seen} seen and {hidden} hidden");
}

/// Each bucket's starts ordered by stride hold, for stride 1, 2 and 4,
/// exactly the bucket's starts at ring positions that are multiples of the
/// stride (the sweep hands over that prefix instead of testing each edge).
#[test]
fn the_strided_start_lists_hold_exactly_the_starts_of_their_stride() {
    let scene = crate::common::generated_scene(200, 3);
    let index = SceneIndex::build(
        &scene.city.buildings,
        &scene.occluders,
        scene.settings.pixel,
    );
    let mut counted = [0usize; 3];
    for b in 0..index.bucket_count() {
        for (k, stride) in [1u32, 2, 4].into_iter().enumerate() {
            let mut want: Vec<u32> = index
                .bucket_starts(b)
                .filter(|&e| index.edges[e as usize].ring_pos.is_multiple_of(stride))
                .collect();
            let mut got: Vec<u32> = index.bucket_starts_strided(b, stride).collect();
            want.sort_unstable();
            got.sort_unstable();
            assert_eq!(got, want, "bucket {b}, stride {stride}");
            counted[k] += got.len();
        }
    }
    // The scene has chains of every stride, and fewer the longer it is.
    assert!(counted[0] > counted[1] && counted[1] > counted[2] && counted[2] > 0);
}
