//! Resumable bakes: a range of cells (a whole bake, or one shard) is solved
//! in chunks that end at every 5 % of its cells and take about 20 s each;
//! after every 5 % (and at least once a minute) the finished prefix is
//! saved atomically to a checkpoint next to the output
//! (`OUTPUT.citypvs-checkpoint`). Run again after a
//! crash, the bake reads the checkpoint, checks that it belongs to the same
//! bake (input hash, every setting, tool version, shard, range, objects and
//! cells) and solves only the cells after the saved prefix. Since a cell's
//! set depends on the scene and the cell only, the result is the same as an
//! uninterrupted bake's.

use std::cell::Cell;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::part::{BakeKey, FrameRecord, Part, PartBuilder, PartKind};
use super::shard::ShardSpec;
use crate::Result;
use crate::bake::{BakeStats, SetTally};
use crate::prepare::{Scene, StageTime};
use crate::visibility::{CHUNK_CELLS, VisibilityEngine};

/// The checkpoint is saved at least this often.
pub const CHECKPOINT_INTERVAL: Duration = Duration::from_secs(60);
/// ... and after every 1/CHECKPOINT_STEPS of the range's cells (5 %).
pub const CHECKPOINT_STEPS: usize = 20;

/// A chunk is sized to take about this many seconds at the pace measured
/// on the chunk before it.
pub const CHUNK_SECONDS: f64 = 20.0;
/// The first chunk's size, before any pace is known.
pub const FIRST_CHUNK_CELLS: usize = 16;

/// Where the checkpoint of a bake writing `output` lives.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let mut name = output.as_os_str().to_owned();
    name.push(".citypvs-checkpoint");
    PathBuf::from(name)
}

/// A part with the header of shard `spec` (covering `range`) of a bake of
/// `scene`, and no sets yet.
pub fn empty_part(scene: &Scene, kind: PartKind, spec: ShardSpec, range: Range<usize>) -> Part {
    Part {
        kind,
        key: BakeKey::of(scene.city.source_hash, &scene.settings),
        frame: FrameRecord::of(&scene.city.frame),
        shard: spec.k as u32,
        shards: spec.n as u32,
        total_cells: scene.cells.triangles.len() as u64,
        range_start: range.start as u64,
        range_end: range.end as u64,
        object_ids: scene.city.buildings.iter().map(|b| b.id.clone()).collect(),
        object_prints: crate::pvs::prints::object_prints(scene),
        cells: scene.cells.triangles[range]
            .iter()
            .map(|t| [t[0].x, t[0].y, t[1].x, t[1].y, t[2].x, t[2].y])
            .collect(),
        block_lens: Vec::new(),
        blocks: Vec::new(),
        loose_lens: Vec::new(),
        loose_runs: Vec::new(),
    }
}

/// What a resumable bake of a range did.
pub struct RangeBake {
    /// The range's cells with their sets, as a part (kind `Shard`).
    pub part: Part,
    pub stats: BakeStats,
    pub timing: StageTime,
    /// Cells whose sets came from a checkpoint.
    pub cells_from_checkpoint: usize,
    /// Checkpoints saved by this run.
    pub checkpoints_written: usize,
}

/// Bake the cells of `range` for the output `output`, resuming from and
/// saving to its checkpoint. `log` gets one line for a checkpoint used or
/// ignored. The checkpoint is left in place: remove it with
/// [`remove_checkpoint`] once the output is written.
pub fn bake_range(
    scene: &Scene,
    engine: &VisibilityEngine,
    spec: ShardSpec,
    range: Range<usize>,
    output: &Path,
    progress: &(dyn Fn(u64) + Sync),
    log: &mut dyn FnMut(String),
) -> Result<RangeBake> {
    let t = Instant::now();
    let cp_path = checkpoint_path(output);
    let mut part = empty_part(scene, PartKind::Checkpoint, spec, range.clone());
    if cp_path.exists() {
        match Part::read(&cp_path) {
            Err(e) => log(format!("ignoring checkpoint {e}; starting over")),
            Ok(saved) if saved.kind != PartKind::Checkpoint => log(format!(
                "ignoring checkpoint {}: it is not a checkpoint; starting over",
                cp_path.display()
            )),
            Ok(saved) => match part.mismatch(&saved) {
                Some(what) => log(format!(
                    "ignoring checkpoint {}: it is of another input or other settings (differs in: {what}); starting over",
                    cp_path.display()
                )),
                None => {
                    log(format!(
                        "resumed from checkpoint: {} of {} cells done",
                        saved.done(),
                        saved.range_len()
                    ));
                    part = saved;
                }
            },
        }
    }
    let from_checkpoint = part.done();
    let mut tally = SetTally::default();
    part.for_each_set(&mut |set| {
        tally.add(set);
        Ok(())
    })?;
    progress(from_checkpoint as u64);

    let mut part = PartBuilder::new(part)?;
    let todo = range.start + from_checkpoint..range.end;
    // Chunks end at the 5 % marks (counted from where this run starts) and
    // are sized from the measured pace to take about CHUNK_SECONDS, so a
    // checkpoint is saved after every 5 % of the cells and at least once a
    // minute even when cells get slower.
    let step = range.len().div_ceil(CHECKPOINT_STEPS).max(1);
    let since_save = Cell::new(0usize);
    let last_save = Cell::new(Instant::now());
    let chunk_end = Cell::new(todo.start);
    let last_chunk: Cell<Option<(usize, Instant)>> = Cell::new(None);
    let next_chunk = |start: usize| {
        let pace = match last_chunk.get() {
            None => FIRST_CHUNK_CELLS,
            Some((cells, began)) => {
                let seconds = began.elapsed().as_secs_f64().max(1e-3);
                ((cells as f64 / seconds) * CHUNK_SECONDS).floor() as usize
            }
        };
        let n = pace
            .min(step - since_save.get().min(step - 1))
            .clamp(1, CHUNK_CELLS);
        last_chunk.set(Some((n, Instant::now())));
        chunk_end.set((start + n).min(todo.end));
        n
    };
    let mut written = 0;
    let mut solve = engine.solve_cells_paced(todo.clone(), next_chunk, progress, |cell, set| {
        tally.add(&set);
        part.push(&set);
        since_save.set(since_save.get() + 1);
        let chunk_done = cell + 1 == chunk_end.get();
        let finished = cell + 1 == todo.end;
        if chunk_done
            && !finished
            && (since_save.get() >= step || last_save.get().elapsed() >= CHECKPOINT_INTERVAL)
        {
            part.part().write(&cp_path)?;
            written += 1;
            since_save.set(0);
            last_save.set(Instant::now());
        }
        Ok(())
    })?;
    // The sample count of the whole range, however much was resumed.
    solve.samples = engine.sample_count(range);
    let mut part = part.into_part();
    part.kind = PartKind::Shard;
    Ok(RangeBake {
        stats: tally.stats(scene.city.buildings.len(), &solve),
        part,
        timing: StageTime {
            stage: "visibility",
            seconds: t.elapsed().as_secs_f64(),
        },
        cells_from_checkpoint: from_checkpoint,
        checkpoints_written: written,
    })
}

/// Remove the checkpoint of `output`, if any (after the output is written).
pub fn remove_checkpoint(output: &Path) -> Result<()> {
    let p = checkpoint_path(output);
    match std::fs::remove_file(&p) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(crate::Error::io(format!(
            "{}: cannot remove the checkpoint: {e}",
            p.display()
        ))),
    }
}
