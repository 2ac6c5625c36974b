//! The incremental bake (`citypvs bake NEW_CITY --previous OLD.pvs`): the
//! cells of the new city whose set cannot have changed since OLD.pvs are
//! copied from it, the others are solved; the sets (and so the file) are
//! those of a full bake of the new city. The argument is in docs/DESIGN.md,
//! "Incremental bakes".
//!
//! Objects are matched by id, cells by their exact corner coordinates. The
//! changed objects X are found with the fingerprint list of OLD.pvs
//! (`crate::pvs::prints`): an object whose own fingerprint or whose
//! occluder neighbourhood's fingerprint (the shrunk polygons of its block
//! that may lie over it) differs, or that is only in one of the two cities. A new cell
//! keeps the old cell's set when (1) no old version of X is in it, (2) no
//! rectangle of X (old or new) comes within the near field of the cell, and
//! (3) every new version of X is hidden from every sample of the cell by the
//! new scene's horizon, with a rounding margin. A cell that passes (2) but
//! not (1) or (3) keeps the verdicts of the objects whose directions miss
//! X's rectangles from all its samples, and is solved for the others only.

use std::borrow::Cow;
use std::collections::HashMap;
use std::path::Path;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::model::Rect;
use crate::prepare::Scene;
use crate::pvs::{BLOCK_CELLS, PvsReader};
use crate::visibility::{SolveStats, VisibilityEngine, WantedObjects};

/// What an incremental bake did, for `bake --json`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct RebakeStats {
    /// Cells whose sets were solved.
    pub cells_recomputed: usize,
    /// Cells whose sets were copied from the previous file.
    pub cells_copied: usize,
    /// Why cells were solved: no identical cell in the previous file ...
    pub cells_new: usize,
    /// ... a changed object was in the old set ...
    pub cells_saw_change: usize,
    /// ... a changed object is within the near field of the cell ...
    pub cells_near_change: usize,
    /// ... or the probe could not show every new version hidden.
    pub cells_probe_failed: usize,
    /// Changed objects: old versions (removed or changed) and new versions
    /// (added or changed).
    pub objects_changed_old: usize,
    pub objects_changed_new: usize,
    /// Of the new versions, those probed (condition 3): the ones whose own
    /// data (footprint, height, occluder flag) changed, and new ones.
    pub objects_probed: usize,
    /// Why every cell was solved, when the previous file could not be used
    /// cell by cell (a different frame, ids that are not unique).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub full_because: Option<String>,
    /// Cells (of those above, except the ones near a change) solved again
    /// only for the objects in the directions of a changed object, and the
    /// sum over them of how many objects that is.
    pub cells_solved_in_part: usize,
    pub objects_solved_in_part: usize,
    /// Seconds spent probing.
    pub probe_seconds: f64,
    /// Blocks of the file whose bytes were copied from the previous file
    /// (every cell copied to the same place, the objects numbered alike).
    pub blocks_copied: usize,
}

/// Refuse a previous file baked with other settings or by another version.
pub fn check_previous(scene: &Scene, old: &PvsReader, path: &Path) -> Result<()> {
    let now = crate::bake::bake_info(scene);
    let was = old.info();
    // The previous file was checked when opened, so its settings are valid.
    let mut differ: Vec<String> = was
        .settings(None)?
        .changed(&scene.settings)
        .into_iter()
        .map(|(name, a, b)| format!("{name} {a} (now {b})"))
        .collect();
    if was.region_hash != now.region_hash {
        differ.push("region".into());
    }
    if was.tool_version != now.tool_version {
        differ.push(format!(
            "citypvs version {} (now {})",
            was.tool_version, now.tool_version
        ));
    }
    if !differ.is_empty() {
        return Err(Error::mismatch(format!(
            "--previous {}: baked with other settings: {}; bake without --previous",
            path.display(),
            differ.join(", ")
        )));
    }
    if old.object_prints().is_empty() && !old.object_ids().is_empty() {
        return Err(Error::mismatch(format!(
            "--previous {}: has no object fingerprints (written by an older citypvs); bake without --previous",
            path.display()
        )));
    }
    Ok(())
}

fn unique<'a>(ids: impl Iterator<Item = &'a str>) -> Option<HashMap<&'a str, u32>> {
    let mut map = HashMap::new();
    for (i, id) in ids.enumerate() {
        if map.insert(id, i as u32).is_some() {
            return None;
        }
    }
    Some(map)
}

/// Where a cell's set comes from in an incremental bake.
pub enum CellSource {
    /// The set of this cell of OLD.pvs, mapped to the new numbering by id.
    Copied(usize),
    /// Solved again: the set itself.
    Solved(Vec<u32>),
}

/// What an incremental bake found it can do.
pub enum Rebake {
    /// Every cell's source, with the solve's and the rebake's statistics.
    Sources(Sources),
    /// OLD.pvs cannot be used cell by cell (the reason): bake in full.
    Full(String),
}

/// Where every cell's set comes from, and what it took.
pub struct Sources {
    pub cells: Vec<CellSource>,
    /// Per object of OLD.pvs, its index in the new city (by id), if it is
    /// there: how a copied cell's set is mapped.
    pub new_of_old: Vec<Option<u32>>,
    /// Per cell of OLD.pvs, how many objects it sees (the size of a copied
    /// cell's set, without decoding it again).
    pub old_lens: Vec<u32>,
    pub solve: SolveStats,
    pub stats: RebakeStats,
}

/// Where every cell's set for the new scene comes from, copying what
/// OLD.pvs allows. Only the sets of the cells solved again are held: a
/// copied cell's set is read from OLD.pvs when it is written
/// ([`rebake_all`]).
pub fn rebake(
    scene: &Scene,
    engine: &VisibilityEngine,
    old: &PvsReader,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Rebake> {
    let cells = &scene.cells.triangles;
    let mut stats = RebakeStats::default();
    if old.info().frame != scene.city.frame {
        return Ok(Rebake::Full(
            "the frame (the centre of the buildings' bounding box) moved".into(),
        ));
    }
    let new_prints = crate::pvs::prints::object_prints(scene);
    let old_prints = old.object_prints();
    let (Some(old_ids), Some(new_ids)) = (
        unique(old.object_ids().iter().map(String::as_str)),
        unique(scene.city.buildings.iter().map(|b| b.id.as_str())),
    ) else {
        return Ok(Rebake::Full("object ids are not unique".into()));
    };

    // X: the changed objects, old and new versions.
    let mut changed_old = vec![false; old_prints.len()];
    let mut rects: Vec<Rect> = Vec::new();
    for (i, id) in old.object_ids().iter().enumerate() {
        let same = new_ids.get(id.as_str()).is_some_and(|&j| {
            let (a, b) = (&old_prints[i], &new_prints[j as usize]);
            a.object == b.object && a.block == b.block
        });
        if !same {
            changed_old[i] = true;
            rects.push(old_prints[i].rect());
        }
    }
    let mut probes: Vec<u32> = Vec::new();
    let mut changed_new: Vec<u32> = Vec::new();
    for (j, b) in scene.city.buildings.iter().enumerate() {
        let old_print = old_ids.get(b.id.as_str()).map(|&i| &old_prints[i as usize]);
        let n = &new_prints[j];
        if old_print.is_some_and(|a| a.object == n.object && a.block == n.block) {
            continue;
        }
        rects.push(n.rect());
        changed_new.push(j as u32);
        // A member whose own data are unchanged (only occluders over it
        // changed) is hidden wherever its old version was: probed only when
        // its own data changed or it is new (docs/DESIGN.md).
        if old_print.is_none_or(|a| a.object != n.object) {
            probes.push(j as u32);
        }
    }
    // A member whose footprint did not move has the same rectangle in both
    // cities; every use of the list asks whether some rectangle does
    // something, so each is kept once.
    rects.sort_unstable_by_key(|r| [r.min.x, r.min.y, r.max.x, r.max.y].map(f64::to_bits));
    rects.dedup();
    stats.objects_changed_old = changed_old.iter().filter(|&&c| c).count();
    stats.objects_changed_new = changed_new.len();
    stats.objects_probed = probes.len();

    // Old cells by their exact triangles (a repeated triangle matches none).
    let mut old_cell: HashMap<[u64; 6], Option<usize>> = HashMap::with_capacity(old.cell_count());
    for (i, t) in old.cell_triangles().iter().enumerate() {
        old_cell
            .entry(super::diff::cell_key(t))
            .and_modify(|e| *e = None)
            .or_insert(Some(i));
    }
    // One pass over the old file (each block decoded once, blocks in
    // parallel): per old cell, whether it holds a member of X_old, and its
    // set's size. Its set is read again only for the cells solved again
    // (below) or when it is written (copied) into a block coded anew.
    let (saw_change, old_lens): (Vec<bool>, Vec<u32>) =
        (0..old.cell_count().div_ceil(old.block_cells()))
            .into_par_iter()
            .map(|b| {
                let sets = old.block_sets(b)?;
                Ok(sets
                    .iter()
                    .map(|set| {
                        let saw = set.iter().any(|&o| changed_old[o as usize]);
                        (saw, set.len() as u32)
                    })
                    .collect::<Vec<(bool, u32)>>())
            })
            .collect::<Result<Vec<Vec<(bool, u32)>>>>()?
            .concat()
            .into_iter()
            .unzip();
    // The near field of every sample of a cell lies in the cell's bounding
    // box grown by the near field and a pixel (the window is pixel-aligned).
    let reach = scene.settings.near_field + 2.0 * scene.settings.pixel;
    let mut sources: Vec<Option<CellSource>> = Vec::with_capacity(cells.len());
    sources.resize_with(cells.len(), || None);
    // Cells to probe, and cells to solve again for the objects in X's
    // directions only, with their old cells.
    let mut candidates: Vec<(usize, usize)> = Vec::new();
    // With each, whether it passed 1 (every old member of X was hidden
    // from its every sample), which rules out new visible objects.
    let mut in_part: Vec<(usize, usize, bool)> = Vec::new();
    for (c, t) in cells.iter().enumerate() {
        let Some(&Some(oc)) = old_cell.get(&super::diff::cell_key(t)) else {
            stats.cells_new += 1;
            continue;
        };
        let near = Rect::of_points(t.iter()).grown(reach);
        if rects.iter().any(|r| r.intersects(&near)) {
            stats.cells_near_change += 1;
            continue;
        }
        if saw_change[oc] {
            stats.cells_saw_change += 1;
            in_part.push((c, oc, false));
        } else {
            candidates.push((c, oc));
        }
    }
    drop(saw_change);
    let t = std::time::Instant::now();
    let list: Vec<usize> = candidates.iter().map(|(c, _)| *c).collect();
    let hidden = engine.probe_cells(&list, &probes);
    stats.probe_seconds = t.elapsed().as_secs_f64();
    for ((c, oc), ok) in candidates.into_iter().zip(hidden) {
        if ok {
            sources[c] = Some(CellSource::Copied(oc));
        } else {
            stats.cells_probe_failed += 1;
            in_part.push((c, oc, true));
        }
    }
    // The old sets of the cells solved in part, mapped to the new
    // numbering, read in the old file's order (each block decoded once,
    // blocks in parallel).
    let new_of_old = new_numbering(old, &new_ids);
    in_part.sort_unstable_by_key(|&(_, oc, _)| oc);
    let in_part = in_part
        .chunk_by(|a, b| a.1 / old.block_cells() == b.1 / old.block_cells())
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|cells| {
            let mut reader = OldSets::new(old, &new_of_old);
            cells
                .iter()
                .map(|&(c, oc, hidden_before)| {
                    Ok(PartCell {
                        cell: c,
                        old_set: reader.set(oc)?,
                        hidden_before,
                    })
                })
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    let part = plan_in_part(engine, in_part, &rects, &changed_new);
    stats.cells_solved_in_part = part.cells.len();
    stats.objects_solved_in_part = part
        .wanted
        .iter()
        .map(|w| w.everywhere.len() + w.where_changed.len())
        .sum();
    let todo: Vec<usize> = (0..cells.len())
        .filter(|&c| sources[c].is_none() && part.cells.binary_search(&c).is_err())
        .collect();
    stats.cells_recomputed = todo.len() + part.cells.len();
    stats.cells_copied = cells.len() - stats.cells_recomputed;
    progress(stats.cells_copied as u64);
    let seen = engine.solve_cells_for(&part.cells, &part.wanted, &rects, progress);
    for ((c, mut kept), seen) in part.cells.into_iter().zip(part.kept).zip(seen) {
        kept.extend(seen);
        kept.sort_unstable();
        sources[c] = Some(CellSource::Solved(kept));
    }
    let (sets, solve) = engine.solve_cell_list(&todo, progress);
    for (c, set) in todo.into_iter().zip(sets) {
        sources[c] = Some(CellSource::Solved(set));
    }
    Ok(Rebake::Sources(Sources {
        cells: sources
            .into_iter()
            .map(|s| s.expect("every cell is copied or solved"))
            .collect(),
        new_of_old,
        old_lens,
        solve,
        stats,
    }))
}

/// Per object of OLD.pvs, its index in the new city (by id), if it is there.
fn new_numbering(old: &PvsReader, new_ids: &HashMap<&str, u32>) -> Vec<Option<u32>> {
    old.object_ids()
        .iter()
        .map(|id| new_ids.get(id.as_str()).copied())
        .collect()
}

/// Reads cells' sets from OLD.pvs mapped to the new numbering (an object
/// that is gone is left out; every object outside X is in the new city
/// under the same id), holding one decoded block: cells asked for in
/// ascending order decode each block once.
struct OldSets<'a> {
    old: &'a PvsReader,
    new_of_old: &'a [Option<u32>],
    block: Option<usize>,
    sets: Vec<Vec<u32>>,
}

impl<'a> OldSets<'a> {
    fn new(old: &'a PvsReader, new_of_old: &'a [Option<u32>]) -> Self {
        OldSets {
            old,
            new_of_old,
            block: None,
            sets: Vec::new(),
        }
    }

    /// Old cell `oc`'s set, ascending in the new numbering.
    fn set(&mut self, oc: usize) -> Result<Vec<u32>> {
        let b = oc / self.old.block_cells();
        if self.block != Some(b) {
            self.sets = self.old.block_sets(b)?;
            self.block = Some(b);
        }
        let mut mapped: Vec<u32> = self.sets[oc % self.old.block_cells()]
            .iter()
            .filter_map(|&o| self.new_of_old[o as usize])
            .collect();
        mapped.sort_unstable();
        Ok(mapped)
    }
}

/// A cell to solve in part, with its old set mapped to the new numbering.
struct PartCell {
    cell: usize,
    old_set: Vec<u32>,
    /// It passed 1 and 2 (only 3 failed): every old member of X was hidden
    /// from its every sample.
    hidden_before: bool,
}

/// The cells solved in part, ascending, with what each is solved for and
/// the members of its old set it keeps.
struct PartPlan {
    cells: Vec<usize>,
    wanted: Vec<WantedObjects>,
    kept: Vec<Vec<u32>>,
}

/// Plan the cells of `in_part` (outside X's near field): each keeps the
/// verdicts of every object that lies beyond no rectangle of X (`rects`)
/// in its directions from any of its samples, and is solved again for the
/// others. A cell with a sample inside a rectangle is left out (solved in
/// full).
fn plan_in_part(
    engine: &VisibilityEngine,
    mut in_part: Vec<PartCell>,
    rects: &[Rect],
    changed_new: &[u32],
) -> PartPlan {
    in_part.sort_unstable_by_key(|p| p.cell);
    let list: Vec<usize> = in_part.iter().map(|p| p.cell).collect();
    let wanted = engine.objects_in_directions(&list, rects, changed_new);
    let mut plan = PartPlan {
        cells: Vec::new(),
        wanted: Vec::new(),
        kept: Vec::new(),
    };
    for (part, wanted) in in_part.into_iter().zip(wanted) {
        // A sample inside a rectangle of X is within its near field, so this
        // does not happen; should it, the cell is solved in full.
        let Some(wanted) = wanted else { continue };
        // An object the old cell did not see was hidden at every sample, so
        // it can only be seen now from a sample in whose changed directions
        // it lies, and not at all when every old member of X was hidden
        // there too (the new horizon is then nowhere lower than the old:
        // docs/DESIGN.md, "Cells that failed only the probe"); one it saw,
        // or a changed object, is tested at every sample.
        let mut w = WantedObjects::default();
        for o in wanted {
            if part.old_set.binary_search(&o).is_ok() || changed_new.binary_search(&o).is_ok() {
                w.everywhere.push(o);
            } else if !part.hidden_before {
                w.where_changed.push(o);
            }
        }
        plan.kept.push(
            part.old_set
                .into_iter()
                .filter(|o| w.everywhere.binary_search(o).is_err())
                .collect(),
        );
        plan.cells.push(part.cell);
        plan.wanted.push(w);
    }
    plan
}

/// [`rebake`] packaged like a checkpointed bake of all cells, for the
/// `bake` command, with its statistics; no bake when OLD.pvs cannot be
/// used cell by cell and the city is to be baked in full (as any bake,
/// streamed; the statistics say why).
pub fn rebake_all(
    scene: &Scene,
    engine: &VisibilityEngine,
    old: &PvsReader,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Option<crate::scale::resume::RangeBake>, RebakeStats)> {
    let t = std::time::Instant::now();
    let cells = scene.cells.triangles.len();
    let Sources {
        cells: sources,
        new_of_old,
        old_lens,
        solve,
        mut stats,
    } = match rebake(scene, engine, old, progress)? {
        Rebake::Sources(sources) => sources,
        Rebake::Full(why) => return Ok((None, RebakeStats::full(cells, why))),
    };
    let mut part = crate::scale::part::PartBuilder::new(crate::scale::resume::empty_part(
        scene,
        crate::scale::part::PartKind::Shard,
        crate::scale::shard::ShardSpec { k: 0, n: 1 },
        0..cells,
    ))?;
    let mut tally = crate::bake::SetTally::default();
    // A block of OLD.pvs whose cells are all copied to the same places is
    // the block the new file would code when both files number the objects
    // alike: its bytes are copied, with its sets' sizes from the first
    // pass over the old file (`old_lens`), not decoded again. The
    // other blocks are coded a few at a time, in parallel (a block's bytes
    // depend only on its cells' sets), and added in order.
    let block = BLOCK_CELLS as usize;
    let same_blocks = old.block_cells() == block
        && old.cell_count() == cells
        && new_of_old.len() == scene.city.buildings.len()
        && new_of_old
            .iter()
            .enumerate()
            .all(|(i, &n)| n == Some(i as u32))
        && part.numbering().is(old.input_of_rank());
    let numbering = part.numbering().clone();
    let blocks: Vec<std::ops::Range<usize>> = (0..cells)
        .step_by(block)
        .map(|c| c..(c + block).min(cells))
        .collect();
    let code = |range: &std::ops::Range<usize>| -> Result<(Cow<'_, [u8]>, Vec<usize>)> {
        let in_place = || {
            sources[range.clone()]
                .iter()
                .zip(range.clone())
                .all(|(s, c)| matches!(s, CellSource::Copied(oc) if *oc == c))
        };
        if same_blocks && in_place() {
            let b = range.start / block;
            let lens = old_lens[range.clone()]
                .iter()
                .map(|&n| n as usize)
                .collect();
            return Ok((Cow::Borrowed(old.coded_block(b)), lens));
        }
        let mut reader = OldSets::new(old, &new_of_old);
        let sets = sources[range.clone()]
            .iter()
            .map(|source| match source {
                CellSource::Copied(oc) => Ok(Cow::Owned(reader.set(*oc)?)),
                CellSource::Solved(set) => Ok(Cow::Borrowed(set.as_slice())),
            })
            .collect::<Result<Vec<Cow<'_, [u32]>>>>()?;
        let lens = sets.iter().map(|s| s.len()).collect();
        Ok((
            Cow::Owned(numbering.code_block(sets.iter().map(|s| &s[..]))),
            lens,
        ))
    };
    for group in blocks.chunks(2 * rayon::current_num_threads()) {
        let coded = group.par_iter().map(code).collect::<Result<Vec<_>>>()?;
        for (range, (bytes, lens)) in group.iter().zip(coded) {
            stats.blocks_copied += usize::from(matches!(bytes, Cow::Borrowed(_)));
            for len in lens {
                tally.add_len(len);
            }
            part.push_coded_block(range.len(), &bytes);
        }
    }
    let solve = SolveStats {
        samples: engine.sample_count(0..cells),
        ..solve
    };
    Ok((
        Some(crate::scale::resume::RangeBake {
            part: part.into_part(),
            stats: tally.stats(scene.city.buildings.len(), &solve),
            timing: crate::prepare::StageTime {
                stage: "visibility",
                seconds: t.elapsed().as_secs_f64(),
            },
            cells_from_checkpoint: 0,
            checkpoints_written: 0,
        }),
        stats,
    ))
}

impl RebakeStats {
    /// An incremental bake that solved all of its `cells` cells because
    /// the previous file could not be used cell by cell (`why`).
    pub fn full(cells: usize, why: String) -> Self {
        RebakeStats {
            cells_recomputed: cells,
            cells_new: cells,
            full_because: Some(why),
            ..RebakeStats::default()
        }
    }
}
