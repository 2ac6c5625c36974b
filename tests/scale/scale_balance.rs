//! Shards cut by probed cost: each cell's cost is its share of the samples
//! times what a probe near it sees, so the shards carry about equal work
//! (samples times visible buildings), not only equal sample counts; the
//! costs are the same for any thread count.

use citypvs::scale::shard::{shard_costs, split};
use citypvs::visibility::VisibilityEngine;

/// The largest shard's work over the mean shard's, for the cells' `work`.
fn heaviest(work: &[u128], ranges: &[std::ops::Range<usize>]) -> f64 {
    let total: u128 = work.iter().sum();
    let most = ranges
        .iter()
        .map(|r| work[r.clone()].iter().sum::<u128>())
        .max()
        .unwrap();
    most as f64 * ranges.len() as f64 / total as f64
}

#[test]
fn probed_costs_balance_the_work_better_than_sample_counts() {
    let scene = crate::common::generated_scene(400, 1);
    let engine = VisibilityEngine::new(&scene).unwrap();
    let sets = engine.solve_all(&|_| {}).unwrap();
    let samples = engine.cell_costs();
    // The work of a cell, by the model the estimate stands for, with its
    // true visible set in place of the probe's count.
    let work: Vec<u128> = samples
        .iter()
        .zip(&sets)
        .map(|(&s, set)| s as u128 * (set.len() as u128 + 1))
        .collect();
    for n in [4, 8, 16] {
        let by_samples = heaviest(&work, &split(&samples, n));
        let by_probes = heaviest(&work, &split(&shard_costs(&engine, n), n));
        assert!(
            by_probes < by_samples && by_probes < 1.25,
            "{n} shards: heaviest shard {by_probes:.3} of the mean by probes, {by_samples:.3} by samples"
        );
    }
}

#[test]
fn probed_costs_are_the_same_for_any_thread_count() {
    let scene = crate::common::generated_scene(150, 3);
    let engine = VisibilityEngine::new(&scene).unwrap();
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| shard_costs(&engine, 8))
    };
    let one = on(1);
    assert_eq!(one.len(), engine.cell_count());
    assert_eq!(one, on(2));
    assert_eq!(one, on(3));
    // One shard needs no probes: the sample counts.
    assert_eq!(shard_costs(&engine, 1), engine.cell_costs());
    // The probes change the costs: some cell's cost is not its samples'.
    assert!(one.iter().zip(engine.cell_costs()).any(|(&a, b)| a != b));
}
