//! Shards: which shard a process bakes (`K/N` or `auto/N` from the batch
//! system's environment), how the cells are split into N contiguous ranges
//! of the Morton order with about equal estimated work (samples, weighted
//! by what probe points nearby see), and how finished
//! shards are checked and merged into the `.pvs` file one whole bake writes.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::part::{Part, PartKind};
use crate::error::{Error, Result};
use crate::pvs::WriteStats;
use crate::visibility::VisibilityEngine;

/// The environment variables `--shard auto/N` reads K from, first set wins:
/// Kubernetes Indexed Jobs, Slurm job arrays, anything else.
pub const SHARD_ENV: [&str; 3] = [
    "JOB_COMPLETION_INDEX",
    "SLURM_ARRAY_TASK_ID",
    "CITYPVS_SHARD",
];

/// The most shards a bake may be split into.
pub const MAX_SHARDS: usize = 1 << 20;

/// Shard K of N (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShardSpec {
    pub k: usize,
    pub n: usize,
}

/// `--shard` as given: a fixed K, or K from the environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardArg {
    Fixed(ShardSpec),
    Auto { n: usize },
}

fn shard_error(m: String) -> Error {
    Error::setting("shard", m)
}

fn parse_count(text: &str, what: &str, arg: &str) -> Result<usize> {
    text.trim().parse::<usize>().map_err(|_| {
        shard_error(format!(
            "{arg}: {what} {text:?} is not a whole number (use K/N or auto/N, e.g. 0/4)"
        ))
    })
}

impl ShardArg {
    /// Parse `K/N` or `auto/N`.
    pub fn parse(arg: &str) -> Result<ShardArg> {
        let Some((k, n)) = arg.split_once('/') else {
            return Err(shard_error(format!(
                "{arg}: expected K/N or auto/N, e.g. 0/4 (shards are numbered from 0)"
            )));
        };
        let n = parse_count(n, "N", arg)?;
        if n == 0 || n > MAX_SHARDS {
            return Err(shard_error(format!(
                "{arg}: N must be between 1 and {MAX_SHARDS}"
            )));
        }
        if k.trim() == "auto" {
            return Ok(ShardArg::Auto { n });
        }
        let k = parse_count(k, "K", arg)?;
        check_k(k, n, arg)?;
        Ok(ShardArg::Fixed(ShardSpec { k, n }))
    }

    /// The shard to bake, and the environment variable K came from (for
    /// `auto/N`). `env` looks a variable up (`std::env::var` in the tool).
    pub fn resolve(
        &self,
        env: impl Fn(&str) -> Option<String>,
    ) -> Result<(ShardSpec, Option<&'static str>)> {
        match *self {
            ShardArg::Fixed(spec) => Ok((spec, None)),
            ShardArg::Auto { n } => {
                let arg = format!("auto/{n}");
                for name in SHARD_ENV {
                    let Some(value) = env(name).filter(|v| !v.trim().is_empty()) else {
                        continue;
                    };
                    let k = value.trim().parse::<usize>().map_err(|_| {
                        shard_error(format!("{arg}: {name}={value:?} is not a shard number"))
                    })?;
                    check_k(k, n, &format!("{arg}: {name}={k}"))?;
                    return Ok((ShardSpec { k, n }, Some(name)));
                }
                Err(shard_error(format!(
                    "{arg}: none of {} is set, so the shard number is unknown",
                    SHARD_ENV.join(", ")
                )))
            }
        }
    }
}

fn check_k(k: usize, n: usize, what: &str) -> Result<()> {
    if k >= n {
        return Err(shard_error(format!(
            "{what}: there is no shard {k} of {n} (shards are numbered 0 to {})",
            n - 1
        )));
    }
    Ok(())
}

/// Probe points per shard for [`shard_costs`], and the fewest and most in
/// all.
pub const PROBES_PER_SHARD: usize = 32;
pub const MIN_PROBES: usize = 256;
pub const MAX_PROBES: usize = 2048;

/// Each cell's estimated cost, for splitting the cells into `n` shards that
/// take about equally long: its share of the samples (see
/// [`VisibilityEngine::cell_costs`]) times one more than the number of
/// objects seen from a probe near it in cell order. The cells are cut into
/// as many stretches as there are probes, and the first corner of each
/// stretch's middle cell is solved in full; the cost of a sample grows with
/// what it sees (docs/performance.md, "Where the time goes as cities grow"), and
/// cells near the city's open edges see more than others. The probes'
/// counts are a function of the scene, so every shard process computes the
/// same costs, and the split decides only which process solves a cell:
/// the merged file is the same for any split.
pub fn shard_costs(engine: &VisibilityEngine, n: usize) -> Vec<usize> {
    let samples = engine.cell_costs();
    let cells = samples.len();
    if n <= 1 || cells == 0 {
        return samples;
    }
    let probes = (PROBES_PER_SHARD.saturating_mul(n))
        .clamp(MIN_PROBES, MAX_PROBES)
        .min(cells);
    let stretch = |j: usize| j * cells / probes..(j + 1) * cells / probes;
    let probe_cells: Vec<usize> = (0..probes)
        .map(|j| {
            let r = stretch(j);
            r.start + r.len() / 2
        })
        .collect();
    let seen = engine.corner_visible_counts(&probe_cells);
    let mut costs = samples;
    for (j, &count) in seen.iter().enumerate() {
        for cost in &mut costs[stretch(j)] {
            *cost = cost.saturating_mul(count + 1);
        }
    }
    costs
}

/// Split cells with the given costs into `n` contiguous ranges (in cell
/// order) of about equal total cost: range k starts at the first cell whose
/// cost prefix reaches k/n of the total. Integer arithmetic, so every
/// process computes the same split.
pub fn split(costs: &[usize], n: usize) -> Vec<Range<usize>> {
    let n = n.max(1);
    let total: u128 = costs.iter().map(|&c| c as u128).sum();
    let mut bounds = vec![0usize; n + 1];
    bounds[n] = costs.len();
    let mut prefix: u128 = 0;
    let mut cell = 0;
    for (k, bound) in bounds.iter_mut().enumerate().take(n).skip(1) {
        // The first cell index i with prefix(i) * n >= k * total.
        while cell < costs.len() && prefix * (n as u128) < (k as u128) * total {
            prefix += costs[cell] as u128;
            cell += 1;
        }
        *bound = cell;
    }
    if total == 0 {
        // No cost information: split by count.
        for (k, bound) in bounds.iter_mut().enumerate() {
            *bound = costs.len() * k / n;
        }
    }
    bounds.windows(2).map(|w| w[0]..w[1]).collect()
}

/// The default shard file name: `CITY.shard-K-of-N` (CITY: the city file's
/// name without its extension).
pub fn default_shard_path(city_stem: &str, spec: ShardSpec) -> PathBuf {
    PathBuf::from(format!("{city_stem}.shard-{}-of-{}", spec.k, spec.n))
}

/// What [`merge_shards`] wrote.
pub struct Merged {
    pub cells: usize,
    pub objects: usize,
    pub write: WriteStats,
}

/// Read and check finished shards and write the `.pvs` file of the whole
/// bake to `output` (nothing is written when a check fails). Refuses
/// (naming the files) shards of different bakes, a missing shard, a shard
/// given twice, a checkpoint, or a truncated or corrupted file.
pub fn merge_shards(paths: &[PathBuf], output: &Path) -> Result<Merged> {
    if paths.is_empty() {
        return Err(Error::usage("merge needs at least one shard file"));
    }
    // Every shard carries the whole object list; the first one read keeps
    // it, the others drop theirs once it is found equal (N copies of a
    // 100,000-building city's ids and fingerprints are some 8 MB each).
    let mut read: Vec<(&Path, Part)> = Vec::with_capacity(paths.len());
    let mut parts: BTreeMap<u32, usize> = BTreeMap::new();
    for path in paths {
        let mut part = Part::read(path)?;
        if part.kind != PartKind::Shard {
            return Err(Error::format(format!(
                "{}: is a checkpoint of an unfinished bake, not a shard; run the same bake command again to finish it",
                path.display()
            )));
        }
        if let Some((p0, f)) = read.first() {
            let keys = f.key.differences(&part.key);
            let mut what: Vec<&str> = keys;
            if f.shards != part.shards {
                what.push("number of shards");
            }
            if f.total_cells != part.total_cells {
                what.push("cell count");
            }
            if f.frame != part.frame {
                what.push("frame");
            }
            if f.object_ids != part.object_ids || f.object_prints != part.object_prints {
                what.push("objects");
            }
            if !what.is_empty() {
                return Err(Error::mismatch(format!(
                    "{} and {} are shards of different bakes ({} differ)",
                    p0.display(),
                    path.display(),
                    what.join(", ")
                )));
            }
            part.object_ids = Vec::new();
            part.object_prints = Vec::new();
        }
        if let Some(&other) = parts.get(&part.shard) {
            return Err(Error::mismatch(format!(
                "shard {} of {} is given twice: {} and {}",
                part.shard,
                part.shards,
                read[other].0.display(),
                path.display()
            )));
        }
        parts.insert(part.shard, read.len());
        read.push((path, part));
    }
    let f = &read[0].1;
    let n = f.shards;
    let missing: Vec<String> = (0..n)
        .filter(|k| !parts.contains_key(k))
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing.iter().take(20).cloned().collect();
        return Err(Error::mismatch(format!(
            "missing shard{} {} of {n} (given: {})",
            if missing.len() == 1 { "" } else { "s" },
            shown.join(", ") + if missing.len() > 20 { ", ..." } else { "" },
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(" ")
        )));
    }
    let mut next = 0u64;
    for &i in parts.values() {
        let (path, part) = &read[i];
        if part.range_start != next {
            return Err(Error::mismatch(format!(
                "{}: shard {} of {n} covers cells {}..{}, but the shards before it end at cell {next}",
                path.display(),
                part.shard,
                part.range_start,
                part.range_end
            )));
        }
        next = part.range_end;
    }
    if next != f.total_cells {
        return Err(Error::mismatch(format!(
            "the shards cover {next} of {} cells",
            f.total_cells
        )));
    }
    let ordered: Vec<&Part> = parts.values().map(|&i| &read[i].1).collect();
    let write = super::part::write_parts(output, f, &ordered)?;
    Ok(Merged {
        cells: f.total_cells as usize,
        objects: f.object_ids.len(),
        write,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_args_parse_and_bad_ones_are_refused() {
        assert_eq!(
            ShardArg::parse("2/4").unwrap(),
            ShardArg::Fixed(ShardSpec { k: 2, n: 4 })
        );
        assert_eq!(ShardArg::parse("auto/8").unwrap(), ShardArg::Auto { n: 8 });
        for bad in ["4/4", "x/4", "1/0", "1", "-1/4", "1/four"] {
            let err = ShardArg::parse(bad).unwrap_err();
            assert_eq!(
                err.kind(),
                &crate::ErrorKind::Setting("shard"),
                "{bad}: {err}"
            );
        }
    }

    #[test]
    fn auto_takes_the_first_variable_set() {
        let arg = ShardArg::parse("auto/4").unwrap();
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                vars.iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        let (spec, from) = arg
            .resolve(env(&[("CITYPVS_SHARD", "1"), ("SLURM_ARRAY_TASK_ID", "3")]))
            .unwrap();
        assert_eq!((spec.k, from), (3, Some("SLURM_ARRAY_TASK_ID")));
        let (spec, from) = arg
            .resolve(env(&[
                ("JOB_COMPLETION_INDEX", "0"),
                ("CITYPVS_SHARD", "2"),
            ]))
            .unwrap();
        assert_eq!((spec.k, from), (0, Some("JOB_COMPLETION_INDEX")));
        let err = arg.resolve(env(&[("CITYPVS_SHARD", "4")])).unwrap_err();
        assert!(err.to_string().contains("no shard 4 of 4"), "{err}");
        let err = arg.resolve(env(&[("CITYPVS_SHARD", "one")])).unwrap_err();
        assert!(err.to_string().contains("not a shard number"), "{err}");
        let err = arg.resolve(env(&[])).unwrap_err();
        assert!(err.to_string().contains("none of"), "{err}");
    }

    #[test]
    fn split_is_contiguous_covering_and_balanced() {
        let costs: Vec<usize> = (0..1000).map(|i| 1 + (i * 7919) % 13).collect();
        for n in [1, 2, 3, 4, 7, 1000, 1500] {
            let ranges = split(&costs, n);
            assert_eq!(ranges.len(), n);
            assert_eq!(ranges[0].start, 0);
            assert_eq!(ranges[n - 1].end, costs.len());
            for w in ranges.windows(2) {
                assert_eq!(w[0].end, w[1].start);
            }
            let total: usize = costs.iter().sum();
            let max = costs.iter().max().unwrap();
            for r in &ranges {
                let c: usize = costs[r.clone()].iter().sum();
                assert!(c <= total / n + 2 * max, "n {n}: {c} of {total}");
            }
        }
        assert_eq!(split(&[0, 0, 0, 0], 2), vec![0..2, 2..4]);
        assert_eq!(split(&[], 3), vec![0..0, 0..0, 0..0]);
    }
}
