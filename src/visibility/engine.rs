//! The visibility engine: built once from a prepared scene (objects,
//! shrunk occluders, cells and settings), it answers "the PVS of one cell",
//! "the PVS of a range of cells, streamed in cell order" and "the cull map
//! of one cell". The bake, the pictures, the judge's reports and the
//! benchmarks all go through it.
//!
//! Work is shared through units: a distinct mesh vertex, or the interior
//! samples of a distinct mesh edge. A unit's visible set is a function of
//! its points and the scene only (never of the order or the thread that
//! solves it), so a cell's PVS (the union of its three corners' and three
//! edges' sets) is the same whether the cell is solved alone, in a range,
//! in a shard or after a resume.
//!
//! Memory: cells are solved in chunks, in cell order. A unit's set is kept
//! only from the chunk that first needs it to the chunk that last needs it
//! (the last use of every unit is known before solving starts); finished
//! cells are handed to the caller's sink at once. Since cells follow a
//! Morton curve, the units alive at any time are those on the border
//! between the cells done and the cells to do, plus one chunk's worth.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::OnceLock;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::bitset::ObjectSet;
use super::horizon::{BinMask, Cover, bins_overlap, covering_of, rect_bins};
use super::index::{ObjectRaster, SceneIndex};
use super::samples::{MeshTopology, cell_sample_points};
use super::solver::{Solver, rect_distance};
use crate::error::{Error, Result};
use crate::model::Rect;
use crate::prepare::Scene;
use crate::settings::Settings;

/// Cells solved together between two hand-overs to the sink.
pub const CHUNK_CELLS: usize = 2048;

/// The most cells a worker thread takes at a time within a chunk.
const CELLS_PER_JOB: usize = 4;

/// What one worker thread solves with: a solver, a scratch object set and
/// the set of the cell being solved.
type Worker<'e> = (Solver<'e>, ObjectSet, ObjectSet);

/// The most pixels the objects' conservative footprints may cover on the
/// global cull-map grid (their spans are found pixel by pixel).
pub const MAX_FOOTPRINT_PIXELS: f64 = 1e8;

/// The most pixels one cull-map picture may hold (4096 x 4096).
pub const MAX_PICTURE_PIXELS: f64 = 16_777_216.0;

/// The largest extent, in metres, of a scene the engine indexes.
pub const MAX_EXTENT: f64 = 1_000_000.0;

/// A unit of shared work, as an index: vertices first, then edges.
type UnitId = u32;

/// A cell's final cull map F (min over its samples of the max over occluder
/// shadows), for pictures and debugging.
#[derive(Clone, Debug)]
pub struct CullMapImage {
    /// Local metres of the lower-left corner of pixel (0, 0).
    pub origin: DVec2,
    /// Pixel size in metres.
    pub pixel: f64,
    pub width: usize,
    pub height: usize,
    /// Row-major shadow heights in metres; row 0 is the southernmost row
    /// (y = origin.y .. origin.y + pixel). 0 means nothing is hidden there.
    pub heights: Vec<f32>,
}

/// A finished visible set, kept in whichever form is smaller: a sorted
/// list (4 bytes per member) or a bitset (one bit per object). So a set
/// held between solving and handing on never takes more than
/// min(4 |set|, objects / 8) bytes, even when a cell sees everything.
struct StoredSet {
    members: Members,
    /// For a corner, the chains its solver carried on after it: the first
    /// sample of an edge starting there (2 eps away) starts from them.
    carried: Vec<u64>,
}

/// The members of a [`StoredSet`].
enum Members {
    Sparse(Vec<u32>),
    Dense(ObjectSet),
}

impl StoredSet {
    fn of(set: &ObjectSet) -> StoredSet {
        let count = set.count();
        let members = if count * 4 * 8 > set.capacity() {
            Members::Dense(set.clone())
        } else {
            Members::Sparse(set.to_vec())
        };
        StoredSet {
            members,
            carried: Vec::new(),
        }
    }

    /// Add every member to `set`.
    fn add_to(&self, set: &mut ObjectSet) {
        match &self.members {
            Members::Sparse(v) => v.iter().for_each(|&o| set.insert(o as usize)),
            Members::Dense(d) => set.union_with(d),
        }
    }

    /// Members in ascending order.
    fn into_vec(self) -> Vec<u32> {
        match self.members {
            Members::Sparse(v) => v,
            Members::Dense(d) => d.to_vec(),
        }
    }
}

/// What a run over a range of cells did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SolveStats {
    /// Distinct sample points of the cells in the range.
    pub samples: usize,
    /// Units (distinct vertices and edges) solved, counting re-solves.
    pub units_solved: usize,
    /// The most unit sets held at once.
    pub peak_units_held: usize,
}

/// Cell-to-object visibility over one prepared scene.
pub struct VisibilityEngine<'a> {
    settings: Settings,
    index: SceneIndex,
    topo: MeshTopology,
    cells: &'a [[DVec2; 3]],
    objects: usize,
}

impl<'a> VisibilityEngine<'a> {
    /// Index the scene. Refuses, before allocating, a scene whose indexes
    /// would be absurdly large for its settings.
    pub fn new(scene: &'a Scene) -> Result<Self> {
        let settings = scene.settings.clone();
        check_index_size(scene, &settings)?;
        let index = SceneIndex::build(&scene.city.buildings, &scene.occluders, settings.pixel);
        let topo = MeshTopology::of(&scene.cells.triangles);
        Ok(VisibilityEngine {
            settings,
            index,
            topo,
            cells: &scene.cells.triangles,
            objects: scene.city.buildings.len(),
        })
    }

    /// The settings the engine works with.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    fn vertex_count(&self) -> usize {
        self.topo.vertices.len()
    }

    /// The units of a cell: its three corners, then its three edges.
    fn cell_units(&self, cell: usize) -> [UnitId; 6] {
        let n = self.vertex_count() as u32;
        let v = self.topo.cell_vertices[cell];
        let e = self.topo.cell_edges[cell];
        [v[0], v[1], v[2], n + e[0], n + e[1], n + e[2]]
    }

    /// The units of `cells`, ascending, each once.
    fn units_of_cells(&self, cells: impl IntoIterator<Item = usize>) -> Vec<UnitId> {
        let mut units: Vec<UnitId> = cells.into_iter().flat_map(|c| self.cell_units(c)).collect();
        units.sort_unstable();
        units.dedup();
        units
    }

    /// The sample points of a unit, in order along its edge.
    fn unit_points(&self, unit: UnitId) -> Vec<DVec2> {
        let n = self.vertex_count();
        let u = unit as usize;
        if u < n {
            vec![self.topo.vertices[u]]
        } else {
            self.topo
                .edge_interior_samples(u - n, self.settings.sample_spacing())
        }
    }

    /// A solver with its two object sets (the scratch set and the cell's).
    fn worker(&self) -> Worker<'_> {
        (
            self.solver(),
            ObjectSet::new(self.objects),
            ObjectSet::new(self.objects),
        )
    }

    fn solver(&self) -> Solver<'_> {
        Solver::new(
            &self.index,
            self.settings.eye_height,
            self.settings.near_field,
        )
    }

    /// The two corner units of an edge unit; none for a corner.
    fn edge_ends(&self, unit: UnitId) -> Option<[UnitId; 2]> {
        let n = self.vertex_count();
        (unit as usize >= n).then(|| self.topo.edges[unit as usize - n])
    }

    /// The set of `unit`, starting from the sets `seed` (for an edge: its
    /// two corners' sets, in the order of [`VisibilityEngine::edge_ends`],
    /// the end its samples start next to first). Its samples then decide
    /// only the objects no corner saw, and since a sample's verdict on an
    /// object does not depend on what is already in the set, the union with
    /// the corners' sets, and so every cell's PVS, is the same as without
    /// the seed.
    fn solve_unit(
        &self,
        solver: &mut Solver,
        scratch: &mut ObjectSet,
        unit: UnitId,
        seed: &[&StoredSet],
    ) -> StoredSet {
        scratch.clear();
        for set in seed {
            set.add_to(scratch);
        }
        let points = self.unit_points(unit);
        let is_corner = self.edge_ends(unit).is_none();
        // An edge's samples start next to its first end: the chains that
        // held that corner's horizon hide most of what they hid there. They
        // change only how soon "hidden" is found (docs/DESIGN.md, "Chains
        // carried along a run").
        if !is_corner && let Some(first_end) = seed.first() {
            solver.set_carried(&first_end.carried);
        }
        solver.solve_run(&points, scratch);
        let mut stored = StoredSet::of(scratch);
        if is_corner {
            stored.carried = solver.carried().to_vec();
        }
        stored
    }

    /// The sample points (x, y, eye height) of one cell's top edges: its
    /// corners and the points along its edges, at most 2 eps apart.
    pub fn cell_samples(&self, cell: usize) -> Vec<DVec3> {
        let h = self.settings.eye_height;
        cell_sample_points(&self.cells[cell], self.settings.sample_spacing())
            .into_iter()
            .map(|p| p.extend(h))
            .collect()
    }

    /// The PVS of one cell: ascending object indices.
    pub fn solve_cell(&self, cell: usize) -> Vec<u32> {
        let mut solver = self.solver();
        let mut scratch = ObjectSet::new(self.objects);
        let mut set = ObjectSet::new(self.objects);
        let units = self.cell_units(cell);
        let corners: Vec<StoredSet> = units[..3]
            .iter()
            .map(|&u| self.solve_unit(&mut solver, &mut scratch, u, &[]))
            .collect();
        for &edge in &units[3..] {
            let ends = self
                .edge_ends(edge)
                .expect("the last three units are edges");
            let seed: Vec<&StoredSet> = ends
                .iter()
                .map(|&e| {
                    &corners[units[..3]
                        .iter()
                        .position(|&u| u == e)
                        .expect("an edge's ends are the cell's corners")]
                })
                .collect();
            self.solve_unit(&mut solver, &mut scratch, edge, &seed)
                .add_to(&mut set);
        }
        corners.iter().for_each(|c| c.add_to(&mut set));
        set.to_vec()
    }

    /// Distinct sample points of the cells in `range`.
    pub fn sample_count(&self, range: Range<usize>) -> usize {
        let mut seen = vec![false; self.vertex_count() + self.topo.edges.len()];
        let mut samples = 0;
        for cell in range {
            for unit in self.cell_units(cell) {
                if !std::mem::replace(&mut seen[unit as usize], true) {
                    samples += self.unit_sample_count(unit);
                }
            }
        }
        samples
    }

    /// Each cell's share of the samples: the samples of the units (corners
    /// and edges) the cell is the first in cell order to use. The sum over
    /// cells `0..i` is `sample_count(0..i)`; the samples factor of the
    /// cost estimate that splits the cells into shards
    /// (`scale::shard::shard_costs`).
    pub fn cell_costs(&self) -> Vec<usize> {
        let mut seen = vec![false; self.vertex_count() + self.topo.edges.len()];
        (0..self.cells.len())
            .map(|cell| {
                self.cell_units(cell)
                    .into_iter()
                    .filter(|&u| !std::mem::replace(&mut seen[u as usize], true))
                    .map(|u| self.unit_sample_count(u))
                    .sum()
            })
            .collect()
    }

    /// How many objects the first corner of each of `cells` sees: that
    /// one point solved in full, in parallel (a unit's set is a function of
    /// its points and the scene, so the counts are the same for any thread
    /// count). An estimate of how costly the cells around it are to solve.
    pub fn corner_visible_counts(&self, cells: &[usize]) -> Vec<usize> {
        cells
            .par_iter()
            .map_init(
                || (self.solver(), ObjectSet::new(self.objects)),
                |(solver, scratch), &cell| {
                    let corner = self.topo.cell_vertices[cell][0];
                    self.solve_unit(solver, scratch, corner, &[]);
                    scratch.count()
                },
            )
            .collect()
    }

    fn unit_sample_count(&self, unit: UnitId) -> usize {
        let n = self.vertex_count();
        let u = unit as usize;
        if u < n {
            1
        } else {
            let [a, b] = self.topo.edges[u - n];
            let (a, b) = (
                self.topo.vertices[a as usize],
                self.topo.vertices[b as usize],
            );
            super::samples::interior_sample_count(a, b, self.settings.sample_spacing())
        }
    }

    /// Solve the cells in `range` and hand each cell's PVS (ascending object
    /// indices) to `sink`, in cell order. `progress` is called with 1 after
    /// each cell is solved. Stops at the first error the sink returns.
    pub fn solve_cells(
        &self,
        range: Range<usize>,
        progress: &(dyn Fn(u64) + Sync),
        sink: impl FnMut(usize, Vec<u32>) -> Result<()>,
    ) -> Result<SolveStats> {
        self.solve_cells_chunked(range, CHUNK_CELLS, progress, sink)
    }

    /// [`VisibilityEngine::solve_cells`] with chunks of `chunk` cells (at
    /// least 1): the sink gets a chunk's cells together, so a caller that
    /// saves its progress (a checkpoint) can do so every `chunk` cells. The
    /// sets are the same for any chunk size.
    pub fn solve_cells_chunked(
        &self,
        range: Range<usize>,
        chunk: usize,
        progress: &(dyn Fn(u64) + Sync),
        sink: impl FnMut(usize, Vec<u32>) -> Result<()>,
    ) -> Result<SolveStats> {
        self.solve_cells_paced(range, |_| chunk, progress, sink)
    }

    /// [`VisibilityEngine::solve_cells`] with chunk sizes chosen as it goes:
    /// `next_chunk(start)` is asked, before each chunk, how many cells
    /// (at least 1) the chunk starting at cell `start` takes, e.g. to end
    /// chunks at checkpoint marks or to keep each chunk short in time. Units
    /// shared across chunks are kept as with fixed chunks; the sets are the
    /// same for any chunk sizes.
    pub fn solve_cells_paced(
        &self,
        range: Range<usize>,
        mut next_chunk: impl FnMut(usize) -> usize,
        progress: &(dyn Fn(u64) + Sync),
        mut sink: impl FnMut(usize, Vec<u32>) -> Result<()>,
    ) -> Result<SolveStats> {
        let range = range.start.min(self.cells.len())..range.end.min(self.cells.len());
        let mut stats = SolveStats {
            samples: self.sample_count(range.clone()),
            ..SolveStats::default()
        };
        // The last cell of the range that uses each unit.
        let mut last_use: HashMap<UnitId, usize> = HashMap::new();
        for cell in range.clone() {
            for unit in self.cell_units(cell) {
                last_use.insert(unit, cell);
            }
        }
        let mut held: HashMap<UnitId, std::sync::Arc<StoredSet>> = HashMap::new();
        // One solver per worker thread for the whole range: the cells are
        // handed out a few at a time (so both threads stay busy to the end
        // of a chunk), and a solver is costly to build. Which solver solves
        // a unit changes no set.
        let workers: Vec<std::sync::Mutex<Worker<'_>>> = (0..rayon::current_num_threads())
            .map(|_| std::sync::Mutex::new(self.worker()))
            .collect();
        let mut start = range.start;
        while start < range.end {
            let end = (start + next_chunk(start).max(1)).min(range.end);
            let needed = self.units_of_cells(start..end);
            let slots: HashMap<UnitId, OnceLock<std::sync::Arc<StoredSet>>> = needed
                .iter()
                .map(|&u| {
                    let slot = OnceLock::new();
                    if let Some(set) = held.get(&u) {
                        let _ = slot.set(set.clone());
                    }
                    (u, slot)
                })
                .collect();
            let solved = std::sync::atomic::AtomicUsize::new(0);
            let sets: Vec<StoredSet> = (start..end)
                .into_par_iter()
                .with_max_len(CELLS_PER_JOB)
                .map(|cell| {
                    // The worker's own solver; a fresh one should a thread
                    // ever come back here while it holds its own.
                    let mut own = rayon::current_thread_index()
                        .and_then(|i| workers.get(i))
                        .and_then(|w| w.try_lock().ok());
                    let mut spare = None;
                    let (solver, scratch, set) = match own.as_deref_mut() {
                        Some(w) => w,
                        None => spare.insert(self.worker()),
                    };
                    set.clear();
                    // Corners first (they come first in a cell's
                    // units), so an edge finds its ends' sets solved.
                    for unit in self.cell_units(cell) {
                        let unit_set = slots[&unit].get_or_init(|| {
                            solved.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            let ends = self.edge_ends(unit).map(|ends| {
                                ends.map(|e| {
                                    slots[&e]
                                        .get()
                                        .expect("a cell's corners are solved before its edges")
                                        .clone()
                                })
                            });
                            let seed: Vec<&StoredSet> =
                                ends.iter().flatten().map(|s| &**s).collect();
                            std::sync::Arc::new(self.solve_unit(solver, scratch, unit, &seed))
                        });
                        unit_set.add_to(set);
                    }
                    progress(1);
                    StoredSet::of(set)
                })
                .collect();
            stats.units_solved += solved.into_inner();
            // Keep the sets that a later chunk still needs.
            held = slots
                .into_iter()
                .filter(|(u, _)| last_use[u] >= end)
                .filter_map(|(u, slot)| slot.into_inner().map(|s| (u, s)))
                .collect();
            stats.peak_units_held = stats.peak_units_held.max(needed.len() + held.len());
            for (k, set) in sets.into_iter().enumerate() {
                sink(start + k, set.into_vec())?;
            }
            start = end;
        }
        Ok(stats)
    }

    /// For each cell of `cells`: true when every object of `objects` is
    /// hidden from every sample of the cell by the horizon of the chains
    /// nearer than it ([`Solver::probe_hidden`]: the object's own test,
    /// with a rounding margin). Units shared by the cells are probed once.
    pub fn probe_cells(&self, cells: &[usize], objects: &[u32]) -> Vec<bool> {
        if objects.is_empty() {
            return vec![true; cells.len()];
        }
        let units = self.units_of_cells(cells.iter().copied());
        let hidden: Vec<bool> = units
            .par_iter()
            .map_init(
                || self.solver(),
                |solver, &unit| {
                    self.unit_points(unit)
                        .iter()
                        .all(|&p| solver.probe_hidden(p, objects))
                },
            )
            .collect();
        let of: HashMap<UnitId, bool> = units.into_iter().zip(hidden).collect();
        cells
            .iter()
            .map(|&c| self.cell_units(c).iter().all(|u| of[u]))
            .collect()
    }

    /// For each cell of `cells`, the objects that, seen from some sample of
    /// the cell, lie in the directions of a change (`ChangeDirections`),
    /// together with `always`: ascending. `None` for a cell with a sample
    /// in one of the rectangles. Only those objects can get another verdict
    /// at the cell's samples when chains inside the rectangles come or go
    /// (docs/DESIGN.md, "Incremental bakes"). A unit shared by cells is
    /// searched once per chunk of [`CHUNK_CELLS`] cells (a cell's list is
    /// the union of its units' lists, whatever the order).
    pub fn objects_in_directions(
        &self,
        cells: &[usize],
        changed: &[Rect],
        always: &[u32],
    ) -> Vec<Option<Vec<u32>>> {
        let mut out = Vec::with_capacity(cells.len());
        for chunk in cells.chunks(CHUNK_CELLS) {
            let units = self.units_of_cells(chunk.iter().copied());
            let found: Vec<Option<Vec<u32>>> = units
                .par_iter()
                .map_init(
                    || ObjectSet::new(self.objects),
                    |marks, &unit| self.unit_objects_in_directions(unit, changed, marks),
                )
                .collect();
            let of: HashMap<UnitId, Option<Vec<u32>>> = units.into_iter().zip(found).collect();
            out.par_extend(chunk.par_iter().map_init(
                || ObjectSet::new(self.objects),
                |marks, &cell| {
                    marks.clear();
                    for unit in self.cell_units(cell) {
                        for &o in of[&unit].as_ref()? {
                            marks.insert(o as usize);
                        }
                    }
                    for &o in always {
                        marks.insert(o as usize);
                    }
                    Some(marks.to_vec())
                },
            ));
        }
        out
    }

    /// The objects that, seen from some sample of `unit`, lie in the
    /// directions of a rectangle of `changed` (ascending; `marks` is
    /// scratch of one bit per object); `None` when a sample lies in one of
    /// the rectangles.
    fn unit_objects_in_directions(
        &self,
        unit: UnitId,
        changed: &[Rect],
        marks: &mut ObjectSet,
    ) -> Option<Vec<u32>> {
        let index = &self.index;
        marks.clear();
        let dirs = self
            .unit_points(unit)
            .iter()
            .map(|&p| ChangeDirections::at(p, changed))
            .collect::<Option<Vec<_>>>()?;
        // One walk for all the samples: a node is entered when it may hold
        // an object for some sample, an object kept when it holds for some
        // sample. Every ancestor of an object that holds for a sample may
        // hold for that sample (`ChangeDirections::may_hold`), so this
        // keeps exactly the objects a walk per sample keeps.
        let mut stack: Vec<u32> = index.root.into_iter().collect();
        while let Some(n) = stack.pop() {
            let node = &index.pyramid[n as usize];
            if !dirs.iter().any(|d| d.may_hold(&node.rect)) {
                continue;
            }
            stack.extend(&node.children);
            for &o in &node.objects {
                let object = &index.objects[o as usize];
                if dirs.iter().any(|d| d.holds(object)) {
                    marks.insert(o as usize);
                }
            }
        }
        Some(marks.to_vec())
    }

    /// For each cell of `cells`, those objects of `wanted[i]` that some
    /// sample of the cell does not hide, where the objects of `everywhere`
    /// are tested at every sample and those of `where_changed` only at the
    /// samples from which they lie in the directions of a rectangle of
    /// `changed` (`ChangeDirections::holds`). Each unit is solved once,
    /// for the objects its cells want, reading at each sample only the bins
    /// that cover the objects it still has to decide there
    /// ([`Solver::solve_point_for`]). `progress` is called with 1 per cell.
    pub fn solve_cells_for(
        &self,
        cells: &[usize],
        wanted: &[WantedObjects],
        changed: &[Rect],
        progress: &(dyn Fn(u64) + Sync),
    ) -> Vec<Vec<u32>> {
        let mut out = Vec::with_capacity(cells.len());
        for (chunk, wanted) in cells.chunks(CHUNK_CELLS).zip(wanted.chunks(CHUNK_CELLS)) {
            // Each unit wants what its cells of the chunk want. The lists
            // are joined one unit at a time, so that only the deduplicated
            // ones are held (joined all at once before deduplication they
            // took 38 MB on a one-building edit of the 10,000-building city).
            let mut cells_of: HashMap<UnitId, Vec<usize>> = HashMap::new();
            for (k, &c) in chunk.iter().enumerate() {
                for u in self.cell_units(c) {
                    cells_of.entry(u).or_default().push(k);
                }
            }
            let mut units: Vec<(UnitId, WantedObjects)> = cells_of
                .into_iter()
                .map(|(u, ks)| {
                    let joined = |list: fn(&WantedObjects) -> &Vec<u32>| {
                        let mut all: Vec<u32> = ks
                            .iter()
                            .flat_map(|&k| list(&wanted[k]).iter().copied())
                            .collect();
                        all.sort_unstable();
                        all.dedup();
                        all.shrink_to_fit();
                        all
                    };
                    let everywhere = joined(|w| &w.everywhere);
                    let mut where_changed = joined(|w| &w.where_changed);
                    where_changed.retain(|o| everywhere.binary_search(o).is_err());
                    (
                        u,
                        WantedObjects {
                            everywhere,
                            where_changed,
                        },
                    )
                })
                .collect();
            units.sort_unstable_by_key(|(u, _)| *u);
            let seen: Vec<Vec<u32>> = units
                .par_iter()
                .map_init(
                    || (self.solver(), ObjectSet::new(self.objects)),
                    |(solver, set), (unit, w)| self.solve_unit_for(solver, set, *unit, w, changed),
                )
                .collect();
            let seen: HashMap<UnitId, Vec<u32>> =
                units.into_iter().map(|(u, _)| u).zip(seen).collect();
            let done: Vec<Vec<u32>> = chunk
                .par_iter()
                .zip(wanted)
                .map(|(&c, w)| {
                    let mut set: Vec<u32> = self
                        .cell_units(c)
                        .iter()
                        .flat_map(|u| seen[u].iter().copied())
                        .filter(|o| {
                            w.everywhere.binary_search(o).is_ok()
                                || w.where_changed.binary_search(o).is_ok()
                        })
                        .collect();
                    set.sort_unstable();
                    set.dedup();
                    progress(1);
                    set
                })
                .collect();
            out.extend(done);
        }
        out
    }

    /// The objects of `w` not hidden from some point of `unit` at which
    /// they are tested (see [`Self::solve_cells_for`]), ascending. At each
    /// point every other object counts as decided, and so does each one
    /// already seen.
    fn solve_unit_for(
        &self,
        solver: &mut Solver,
        set: &mut ObjectSet,
        unit: UnitId,
        w: &WantedObjects,
        changed: &[Rect],
    ) -> Vec<u32> {
        let mut seen: Vec<u32> = Vec::new();
        // The objects still to decide (those seen at an earlier sample
        // count as decided), with, per sample, each one tested there and its
        // bins from the sample.
        let mut everywhere = w.everywhere.clone();
        let mut where_changed = w.where_changed.clone();
        let mut tested_here: Vec<bool> = Vec::with_capacity(where_changed.len());
        let mut todo: Vec<u32> = Vec::new();
        let mut todo_bins: Vec<Option<(i64, i64)>> = Vec::new();
        let object = |o: u32| &self.index.objects[o as usize];
        for p in self.unit_points(unit) {
            todo.clear();
            todo_bins.clear();
            tested_here.clear();
            for &o in &everywhere {
                todo.push(o);
                todo_bins.push(rect_bins(p, &object(o).rect));
            }
            if !where_changed.is_empty() {
                // A sample inside a changed rectangle tests them all.
                let dirs = ChangeDirections::at(p, changed);
                for &o in &where_changed {
                    let bins = rect_bins(p, &object(o).rect);
                    let tested = dirs.as_ref().is_none_or(|d| d.holds_with(object(o), bins));
                    if tested {
                        todo.push(o);
                        todo_bins.push(bins);
                    }
                    tested_here.push(tested);
                }
            }
            if todo.is_empty() {
                continue;
            }
            let interest = match covering_of(todo_bins.iter().copied()) {
                Cover::Bins(lo, hi) => Some((lo, hi)),
                Cover::Nothing | Cover::Everything => None,
            };
            set.fill(self.objects);
            for &o in &todo {
                set.remove(o as usize);
            }
            solver.solve_point_for(p, interest, &todo, set);
            let found = |o: &u32| set.contains(*o as usize);
            seen.extend(todo.iter().filter(|o| found(o)));
            everywhere.retain(|o| !found(o));
            let mut tested = tested_here.iter();
            where_changed.retain(|o| {
                let tested = tested.next().is_some_and(|&t| t);
                !(tested && found(o))
            });
        }
        seen.sort_unstable();
        seen
    }

    /// The PVS of each cell of `cells` (ascending object indices), in the
    /// order given: the sets [`VisibilityEngine::solve_cells`] gives those
    /// cells. Cells are taken in chunks of [`CHUNK_CELLS`]; the units of a
    /// chunk are solved once.
    pub fn solve_cell_list(
        &self,
        cells: &[usize],
        progress: &(dyn Fn(u64) + Sync),
    ) -> (Vec<Vec<u32>>, SolveStats) {
        let mut stats = SolveStats::default();
        let mut out = Vec::with_capacity(cells.len());
        for chunk in cells.chunks(CHUNK_CELLS) {
            let units = self.units_of_cells(chunk.iter().copied());
            stats.units_solved += units.len();
            stats.peak_units_held = stats.peak_units_held.max(units.len());
            stats.samples += units
                .iter()
                .map(|&u| self.unit_sample_count(u))
                .sum::<usize>();
            // Corners (the lower ids) first, then the edges seeded with
            // their ends' sets.
            let edges_from = units.partition_point(|&u| self.edge_ends(u).is_none());
            let solve = |units: &[UnitId], of: &HashMap<UnitId, StoredSet>| -> Vec<StoredSet> {
                units
                    .par_iter()
                    .map_init(
                        || (self.solver(), ObjectSet::new(self.objects)),
                        |(solver, scratch), &unit| {
                            let seed: Vec<&StoredSet> = self
                                .edge_ends(unit)
                                .iter()
                                .flatten()
                                .map(|e| &of[e])
                                .collect();
                            self.solve_unit(solver, scratch, unit, &seed)
                        },
                    )
                    .collect()
            };
            let mut of: HashMap<UnitId, StoredSet> = HashMap::new();
            let corner_sets = solve(&units[..edges_from], &of);
            of.extend(units[..edges_from].iter().copied().zip(corner_sets));
            let edge_sets = solve(&units[edges_from..], &of);
            of.extend(units[edges_from..].iter().copied().zip(edge_sets));
            let done: Vec<Vec<u32>> = chunk
                .par_iter()
                .map_init(
                    || ObjectSet::new(self.objects),
                    |set, &c| {
                        set.clear();
                        for u in self.cell_units(c) {
                            of[&u].add_to(set);
                        }
                        progress(1);
                        set.to_vec()
                    },
                )
                .collect();
            out.extend(done);
        }
        (out, stats)
    }

    /// Every cell's PVS, in cell order (holds them all: for tests and small
    /// scenes; the bake streams with [`VisibilityEngine::solve_cells`]).
    pub fn solve_all(&self, progress: &(dyn Fn(u64) + Sync)) -> Result<Vec<Vec<u32>>> {
        let mut out = Vec::with_capacity(self.cells.len());
        self.solve_cells(0..self.cells.len(), progress, |_, set| {
            out.push(set);
            Ok(())
        })?;
        Ok(out)
    }

    /// The final cull map of one cell over the square of half-size `radius`
    /// (metres) around the cell. Refuses pictures over the pixel limit.
    pub fn cull_map(&self, cell: usize, radius: f64) -> Result<CullMapImage> {
        if cell >= self.cells.len() {
            return Err(Error::usage(format!(
                "cell {cell} does not exist (the scene has {} cells, numbered from 0)",
                self.cells.len()
            )));
        }
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::setting(
                "radius",
                format!("must be a positive number of metres, got {radius}"),
            ));
        }
        let t = self.cells[cell];
        let rect = Rect::of_points(t.iter()).grown(radius);
        let pixel = self.settings.pixel;
        let columns = (rect.max.x / pixel).floor() - (rect.min.x / pixel).floor() + 1.0;
        let rows = (rect.max.y / pixel).floor() - (rect.min.y / pixel).floor() + 1.0;
        let pixels = columns * rows;
        if pixels.is_nan() || pixels > MAX_PICTURE_PIXELS {
            let cell_size = rect.width().max(rect.height()) - 2.0 * radius;
            let largest = ((MAX_PICTURE_PIXELS.sqrt() - 2.0) * pixel - cell_size) / 2.0;
            return Err(Error::limit(
                "radius",
                format!(
                    "--radius {radius} m makes cell {cell}'s cull map {columns:.0} x {rows:.0} pixels of {pixel:.3} m \
                     ({pixels:.3e} pixels, {:.3e} bytes), more than the {MAX_PICTURE_PIXELS:.0} accepted: give --radius {:.0} \
                     or less",
                    pixels * 8.0,
                    largest.floor().max(0.0)
                ),
            ));
        }
        let mut solver = self.solver();
        let (i0, j0) = self.index.grid.pixel_of(rect.min);
        let (i1, j1) = self.index.grid.pixel_of(rect.max);
        let (width, height) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
        let mut min_map = vec![f32::INFINITY; width * height];
        for s in self.cell_samples(cell) {
            solver.window.reset(i0, j0, width, height);
            solver.rasterise_occluders(s.truncate());
            for (m, u) in min_map.iter_mut().zip(&solver.window.heights) {
                *m = m.min(*u);
            }
        }
        Ok(CullMapImage {
            origin: DVec2::new(i0 as f64 * pixel, j0 as f64 * pixel),
            pixel,
            width,
            height,
            heights: min_map,
        })
    }
}

/// The objects an incremental bake solves a cell again for: those tested
/// at every sample, and those tested only at the samples from which they
/// lie in the directions of a change (both ascending).
#[derive(Clone, Debug, Default)]
pub struct WantedObjects {
    pub everywhere: Vec<u32>,
    pub where_changed: Vec<u32>,
}

/// Seen from one point, the directions of a set of changed rectangles:
/// per rectangle its bins (of [`rect_bins`], grown by a bin on each side)
/// and its nearest distance, and the union of those bins.
pub struct ChangeDirections {
    p: DVec2,
    dirs: Vec<(i64, i64, f64)>,
    /// Every bin of some rectangle's grown bins: a range that misses it
    /// overlaps none of them.
    union: BinMask,
}

impl ChangeDirections {
    /// `None` when `p` is in one of the rectangles.
    pub fn at(p: DVec2, changed: &[Rect]) -> Option<Self> {
        let dirs = changed
            .iter()
            .map(|r| rect_bins(p, r).map(|(a, b)| (a - 1, b + 1, rect_distance(p, r))))
            .collect::<Option<Vec<_>>>()?;
        let mut union = BinMask::default();
        for &(a, b, _) in &dirs {
            union.insert(a, b);
        }
        Some(ChangeDirections { p, dirs, union })
    }

    /// Whether an object lies farther than some changed rectangle (at the
    /// distance its horizon test takes its slope at), in bins that meet
    /// its grown bins (those of its rectangle, which hold the bins its test
    /// reads): only then can a chain inside that rectangle be in the
    /// object's horizon and raise one of the bins its test reads (a chain
    /// enters before an item only when it is nearer, and raises only bins
    /// inside its rectangle's).
    pub fn holds(&self, object: &ObjectRaster) -> bool {
        self.holds_with(object, rect_bins(self.p, &object.rect))
    }

    /// [`Self::holds`] given the object's [`rect_bins`] from the point.
    pub fn holds_with(&self, object: &ObjectRaster, bins: Option<(i64, i64)>) -> bool {
        let Some(bins) = bins else {
            return true;
        };
        // Its bins meet none of the rectangles' (the union's test is the
        // overlap test of each range in turn), so its distance is not needed.
        if !self.union.meets(bins.0, bins.1) {
            return false;
        }
        let beyond = |d: f64| {
            self.dirs
                .iter()
                .any(|&(a, b, near)| d > near && bins_overlap(bins, (a, b)))
        };
        // The rectangle's distance is no greater than the distance the test
        // takes (the hull's, or the rectangle's), so beyond a rectangle at
        // it, the object is beyond it at that one too; the hull's distance
        // is found only when this does not settle it. (Should rounding put
        // the hull's distance a hair below the rectangle's, the object is
        // tested at one more sample, which gives it the full bake's verdict
        // there: the sets cannot change.)
        beyond(rect_distance(self.p, &object.rect)) || beyond(object.distance_from(self.p).0)
    }

    /// Whether a pyramid node with this rectangle may hold an object that
    /// [`Self::holds`]: its bins, grown by one more bin against rounding,
    /// meet those of a changed rectangle (the bins of everything below a
    /// node lie in the node's). Growing the node's bins by one instead of
    /// each rectangle's asks the same of each pair.
    pub fn may_hold(&self, rect: &Rect) -> bool {
        let Some(bins) = rect_bins(self.p, rect) else {
            return true;
        };
        self.union.meets(bins.0 - 1, bins.1 + 1)
    }
}

/// Refuse, before building anything, a scene whose indexes would not fit:
/// an extent beyond [`MAX_EXTENT`], object footprints covering more than
/// [`MAX_FOOTPRINT_PIXELS`] pixels at the settings' pixel size, or
/// occluders cut into more than [`super::index::MAX_INDEX_POINTS`] points.
fn check_index_size(scene: &Scene, settings: &Settings) -> Result<()> {
    let mut bounds = Rect::EMPTY;
    for t in &scene.cells.triangles {
        for p in t {
            bounds.include(*p);
        }
    }
    let mut pixels = 0.0;
    for b in &scene.city.buildings {
        let r = crate::model::multipolygon_bounds(&b.footprint);
        bounds.include(r.min);
        bounds.include(r.max);
        pixels += (r.width() / settings.pixel + 3.0) * (r.height() / settings.pixel + 3.0);
    }
    if !bounds.is_empty() && (bounds.width() > MAX_EXTENT || bounds.height() > MAX_EXTENT) {
        return Err(Error::limit(
            "region",
            format!(
                "the scene is {:.0} m x {:.0} m, more than the limit of {MAX_EXTENT} m a side; check the input's \
                 coordinates or bake a smaller region",
                bounds.width(),
                bounds.height()
            ),
        ));
    }
    let points = SceneIndex::points_needed(&scene.occluders);
    if points > super::index::MAX_INDEX_POINTS {
        return Err(Error::limit(
            "occluder pieces",
            format!(
                "the {} shrunk occluder levels cut into pieces of at most {} m need {points} points in the \
                 occluder index, more than the {} it can hold; check the footprints for sides of absurd \
                 length, or bake a smaller region",
                scene.occluders.len(),
                super::index::MAX_EDGE_PIECE,
                super::index::MAX_INDEX_POINTS
            ),
        ));
    }
    if pixels > MAX_FOOTPRINT_PIXELS {
        return Err(Error::limit(
            "pixel",
            format!(
                "a cull-map pixel of {} m puts the {} buildings' footprints on {pixels:.3e} pixels, more than the \
                 {MAX_FOOTPRINT_PIXELS:.0e} accepted; use a larger --pixel or --eps",
                settings.pixel,
                scene.city.buildings.len()
            ),
        ));
    }
    Ok(())
}
