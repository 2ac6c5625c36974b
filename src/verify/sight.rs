//! Exact visibility of buildings from one viewpoint, against the original
//! footprints at their true heights.
//!
//! The azimuths of footprint vertices, of the points where footprints of
//! different buildings cross, and of a coarse fan cut the directions around
//! the viewpoint into wedges. Inside one open wedge no ray passes such a
//! point, so every ray crosses the same edges in the same order. Vertices
//! beyond `FIRST_REACH` cut a wedge only when its walk reaches them (only
//! the part of the wedge the walk judged has to be free of them;
//! docs/verify.md, "Wedges cut as far as the walk goes"). In the
//! vertical plane of a ray a building is a set of rectangles; the best point
//! to see of one is the top of the wall the ray enters it by when it is at
//! least as high as the eye, and otherwise the far end of its roof (or the
//! foot of a taller building's wall standing on that roof). A sight line
//! clears an earlier building iff it passes above that same kind of corner.
//! So with elevations `(H - z) / distance` of those corners, a building is
//! seen iff its elevation reaches every earlier occluding one's, and it is
//! not inside a taller building there.
//!
//! The distance along direction `u` to an edge's line is `c / cross(u, e)`,
//! so every elevation is a linear function of `u`. Writing `u = m + s m_perp`
//! over the wedge (`m` its middle direction), elevations are straight lines
//! in `s`, the running horizon is their upper envelope, and "seen somewhere in
//! the wedge" is an exact test at the envelope's breakpoints. One ray per
//! wedge (through its middle) finds the crossings; nothing between rays is
//! sampled or missed.

use glam::{DVec2, DVec3};

use super::beyond::HeightsBeyond;
use super::buckets::{Buckets, sort_in_buckets};
use super::edges::{Crossing, EdgeGrid, RayScratch};
use super::envelope::{Envelope, Line};
use crate::model::{
    Building, Rect, distance_to_segment, multipolygon_bounds, point_in_multipolygon, polygon_edges,
};
use crate::pvs::mesh::SNAP_DISTANCE;

/// Extra wedge boundaries, evenly spaced, so that no wedge is wider than
/// 2 pi / FAN_DIRECTIONS (the `s` parameter stays small).
const FAN_DIRECTIONS: usize = 16;
/// Wedges narrower than this (radians) are left out: they lie between two
/// azimuths equal up to rounding, and each neighbour's closed wedge already
/// includes their boundary directions.
const MIN_WEDGE: f64 = 1e-11;
/// Crossings of a ray this near each other (relative to their distance)
/// are at one distance: the tolerance within which the judge counts sight
/// lines as touching.
const TIE: f64 = 1e-9;
/// Vertices nearer than this (metres) cut the directions into wedges from
/// the start; farther ones cut a wedge only when its walk reaches them.
const FIRST_REACH: f64 = 30.0;
/// An elevation for an edge whose line passes through the viewpoint.
const HUGE_ELEVATION: f64 = 1e30;
/// A viewpoint inside an occluding building by at most this much (metres)
/// is moved out of it. Cell edges run along footprint outlines, and a file
/// stores cell corners on its grid of 1/256 m, so a cell may reach half a
/// grid square's diagonal into a building ([`SNAP_DISTANCE`], 2.8 mm); its
/// set must hold from every point that near its triangle (docs/METHOD.md,
/// "Cell corners on a grid"). A micrometre more allows for rounding.
pub const MAX_SNAP: f64 = SNAP_DISTANCE + 1e-6;
/// A viewpoint this near an occluding outline (metres) counts as on it, and
/// is moved off it as one inside would be.
const ON_OUTLINE: f64 = 1e-9;
/// How far outside the outline a moved viewpoint is put (metres).
const SNAP_CLEARANCE: f64 = 1e-6;
/// Rings (evenly spaced out to [`MAX_SNAP`]) and points per ring searched
/// for a free point near a viewpoint between buildings that touch: a point
/// every 0.05 mm or less, so that cracks of a tenth of a millimetre between
/// misaligned walls are found.
const FREE_RINGS: usize = 64;
const FREE_DIRECTIONS: usize = 512;

/// One building seen from a viewpoint, and a point of it that is seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sighting {
    pub building: u32,
    pub witness: DVec3,
}

/// What one viewpoint sees.
#[derive(Clone, Debug, PartialEq)]
pub enum View {
    /// The buildings seen, ascending by building index, from `from` (the
    /// viewpoint, or the point within [`MAX_SNAP`] outside a building it was
    /// moved to).
    Seen {
        from: DVec3,
        sightings: Vec<Sighting>,
        rays: u64,
    },
    /// The viewpoint is inside this occluding building, deeper than
    /// [`MAX_SNAP`] (`depth`: its distance to the outline): nothing can be
    /// judged.
    InsideBuilding { building: u32, depth: f64 },
}

/// The judge's view of the city: buildings, their edges in a grid, and their
/// vertices.
#[derive(Debug)]
pub struct Judge<'a> {
    buildings: &'a [Building],
    grid: EdgeGrid,
    /// Every footprint vertex with its building.
    vertices: Vec<(DVec2, u32)>,
    /// Where edges of different buildings cross (overlapping footprints):
    /// the order of crossings along a ray changes there too.
    overlaps: Vec<DVec2>,
    bounds: Vec<Rect>,
    /// Vertices this near a viewpoint cut its directions before any walk.
    first_reach: f64,
}

/// Per-thread working memory of [`Judge::view`].
#[derive(Debug, Default)]
pub struct Scratch {
    ray: RayScratch,
    envelope: Envelope,
    /// Every vertex and crossing as (azimuth, distance), ascending by
    /// azimuth, one entry per azimuth (the nearest), with the fan at
    /// distance 0.
    directions: Vec<(f64, f64)>,
    /// Working memory of the directions' sort.
    by_bucket: Buckets<(f64, f64)>,
    /// Wedges still to judge, as indices into `directions` (the second may
    /// be past the end: the same entry a turn later); the next is last.
    wedges: Vec<(usize, usize)>,
    /// Where a wedge is cut: indices into `directions`.
    cuts: Vec<usize>,
    /// One building's vertex azimuths, while `beyond` is built.
    building_azimuths: Vec<Option<f64>>,
    beyond: HeightsBeyond,
    seen: Marks,
    /// Buildings the ray is inside of: (building, edge it entered by).
    open: Vec<(u32, Option<u32>)>,
    /// Crossings at one distance, in the order they are taken.
    ties: Vec<Crossing>,
}

/// The buildings seen so far from one viewpoint (each with a point of it
/// seen), and which of them the wedge being judged marked, so that those
/// marks can be taken back if the wedge has to be cut after all.
#[derive(Debug, Default)]
struct Marks {
    seen: Vec<Option<DVec3>>,
    fresh: Vec<u32>,
}

impl Marks {
    fn start(&mut self, buildings: usize) {
        self.seen.clear();
        self.seen.resize(buildings, None);
        self.fresh.clear();
    }

    fn is_seen(&self, building: u32) -> bool {
        self.seen[building as usize].is_some()
    }

    fn mark(&mut self, building: u32, witness: DVec3) {
        if !self.is_seen(building) {
            self.seen[building as usize] = Some(witness);
            self.fresh.push(building);
        }
    }

    /// The wedge's marks stand.
    fn keep(&mut self) {
        self.fresh.clear();
    }

    /// The wedge's marks are taken back.
    fn take_back(&mut self) {
        for b in self.fresh.drain(..) {
            self.seen[b as usize] = None;
        }
    }

    /// Every building seen, ascending, with its point seen.
    fn sightings(&self) -> impl Iterator<Item = Sighting> + '_ {
        self.seen.iter().enumerate().filter_map(|(i, w)| {
            w.map(|witness| Sighting {
                building: i as u32,
                witness,
            })
        })
    }
}

/// The point of `building`'s outline nearest to `p`, the distance, and the
/// direction from the solid towards the outside there.
fn nearest_outline_point(building: &Building, p: DVec2) -> (DVec2, f64, DVec2) {
    let mut best = (p, f64::INFINITY, DVec2::X);
    for poly in &building.footprint {
        for (a, b) in polygon_edges(poly) {
            let e = b - a;
            let len2 = e.length_squared();
            if len2 == 0.0 {
                continue;
            }
            let t = ((p - a).dot(e) / len2).clamp(0.0, 1.0);
            let foot = a + e * t;
            let d = foot.distance(p);
            if d < best.1 {
                // Exteriors run counter-clockwise and holes clockwise, so the
                // solid is on the left of every edge: outside is to the right.
                let right = DVec2::new(e.y, -e.x).normalize();
                let outward = if d > 1e-12 { (foot - p) / d } else { right };
                best = (foot, d, outward);
            }
        }
    }
    best
}

/// One wedge of directions being judged.
struct Wedge {
    origin: DVec2,
    z: f64,
    mid: DVec2,
    perp: DVec2,
    /// The azimuths of its two borders (radians; the second may be past
    /// pi).
    azimuths: (f64, f64),
}

impl Wedge {
    /// The elevation `dh / distance` of the line of `edge`, as a line in `s`.
    fn elevation(&self, grid: &EdgeGrid, edge: u32, dh: f64) -> Line {
        let e = &grid.edges[edge as usize];
        let along = e.b - e.a;
        let c = (e.a - self.origin).perp_dot(along);
        if c.abs() <= 1e-300 {
            return Line {
                at0: dh.signum() * HUGE_ELEVATION,
                slope: 0.0,
            };
        }
        Line {
            at0: dh * self.mid.perp_dot(along) / c,
            slope: dh * self.perp.perp_dot(along) / c,
        }
    }

    /// The point where the ray of parameter `s` meets the line of `edge`, at height `h`.
    fn point_on(&self, grid: &EdgeGrid, edge: u32, s: f64, h: f64) -> DVec3 {
        let e = &grid.edges[edge as usize];
        let along = e.b - e.a;
        let u = (self.mid + self.perp * s).normalize();
        let t = (e.a - self.origin).perp_dot(along) / u.perp_dot(along);
        let p = self.origin + u * t;
        DVec3::new(p.x, p.y, h)
    }
}

impl<'a> Judge<'a> {
    pub fn new(buildings: &'a [Building]) -> Judge<'a> {
        let grid = EdgeGrid::new(buildings);
        let vertices = buildings
            .iter()
            .enumerate()
            .flat_map(|(i, b)| {
                b.footprint.iter().flat_map(move |p| {
                    std::iter::once(&p.exterior)
                        .chain(p.holes.iter())
                        .flat_map(move |r| r.iter().map(move |v| (*v, i as u32)))
                })
            })
            .collect();
        let bounds = buildings
            .iter()
            .map(|b| multipolygon_bounds(&b.footprint))
            .collect();
        let overlaps = grid.crossings_between_buildings();
        Judge {
            buildings,
            grid,
            vertices,
            overlaps,
            bounds,
            first_reach: FIRST_REACH,
        }
    }

    /// The same judge with every vertex within `metres` of a viewpoint
    /// cutting its directions before any walk (farther ones cut a wedge
    /// only when its walk reaches them). Any distance gives the same
    /// verdicts; infinity gives one wedge between each two neighbouring
    /// vertex directions, the simplest form of the argument, which tests
    /// compare with.
    pub fn with_first_cuts_within(mut self, metres: f64) -> Self {
        self.first_reach = metres;
        self
    }

    /// Every building seen from `viewpoint`, each with a point of it seen.
    pub fn view(&self, viewpoint: DVec3, scratch: &mut Scratch) -> View {
        let origin = match self.free_position(viewpoint.truncate()) {
            Ok(p) => p,
            Err((building, depth)) => return View::InsideBuilding { building, depth },
        };
        let z = viewpoint.z;
        scratch.seen.start(self.buildings.len());
        let mut lifted_around = Vec::new();
        for (i, b) in self.buildings.iter().enumerate() {
            if !b.occludes && self.contains(i, origin) {
                // Standing under a lifted part: it is overhead, hence seen.
                lifted_around.push(i as u32);
                scratch
                    .seen
                    .mark(i as u32, DVec3::new(origin.x, origin.y, b.height));
            }
        }
        scratch.seen.keep();
        self.collect_directions(origin, scratch);
        let beyond = std::mem::take(&mut scratch.beyond);
        let directions = std::mem::take(&mut scratch.directions);
        let n = directions.len();
        let azimuth = |i: usize| match i.checked_sub(n) {
            None => directions[i].0,
            Some(j) => directions[j].0 + std::f64::consts::TAU,
        };
        let distance = |i: usize| directions[i % n].1;
        // The first cuts: the fan and every vertex within FIRST_REACH,
        // judged in the order of their directions.
        scratch.cuts.clear();
        scratch
            .cuts
            .extend((0..n).filter(|&i| directions[i].1 <= self.first_reach));
        scratch.wedges.clear();
        if let (Some(&first), Some(&last)) = (scratch.cuts.first(), scratch.cuts.last()) {
            scratch.wedges.push((last, first + n));
            scratch
                .wedges
                .extend(scratch.cuts.windows(2).rev().map(|w| (w[0], w[1])));
        }
        let mut rays = 0u64;
        while let Some((i0, i1)) = scratch.wedges.pop() {
            let (a0, a1) = (azimuth(i0), azimuth(i1));
            let width = a1 - a0;
            if width < MIN_WEDGE {
                continue;
            }
            let centre = a0 + 0.5 * width;
            let mid = DVec2::new(centre.cos(), centre.sin());
            let wedge = Wedge {
                origin,
                z,
                mid,
                perp: mid.perp(),
                azimuths: (a0, a1),
            };
            let reach = (0.5 * width).tan();
            scratch.envelope.reset(-reach, reach);
            scratch.open.clear();
            scratch
                .open
                .extend(lifted_around.iter().map(|&b| (b, None)));
            rays += 1;
            let judged_out_to = self.judge_wedge(&wedge, &beyond, scratch);
            // A vertex inside the wedge no farther than what the walk
            // judged may change which edges its rays cross there: the
            // verdicts are taken back and the wedge is cut at every such
            // vertex (docs/verify.md, "Wedges cut as far as the walk goes").
            scratch.cuts.clear();
            scratch
                .cuts
                .extend((i0 + 1..i1).filter(|&i| distance(i) <= judged_out_to));
            if scratch.cuts.is_empty() {
                scratch.seen.keep();
                continue;
            }
            scratch.seen.take_back();
            scratch.cuts.push(i1);
            let Scratch { wedges, cuts, .. } = &mut *scratch;
            // The pieces from i0 through the cuts to i1, the first on top.
            wedges.extend(
                (0..cuts.len())
                    .rev()
                    .map(|k| (if k == 0 { i0 } else { cuts[k - 1] }, cuts[k])),
            );
        }
        scratch.beyond = beyond;
        scratch.directions = directions;
        let sightings = scratch.seen.sightings().collect();
        View::Seen {
            from: origin.extend(z),
            sightings,
            rays,
        }
    }

    fn contains(&self, building: usize, p: DVec2) -> bool {
        self.bounds[building].contains_point(p)
            && point_in_multipolygon(p, &self.buildings[building].footprint)
    }

    /// True when `p` lies in `building` or on its outline (within
    /// [`ON_OUTLINE`]): a viewpoint on a wall is moved off it like one
    /// inside, since rays that start on a wall do not see it as crossed.
    fn holds(&self, building: usize, p: DVec2) -> bool {
        let b = &self.buildings[building];
        self.bounds[building].grown(ON_OUTLINE).contains_point(p)
            && (point_in_multipolygon(p, &b.footprint)
                || nearest_outline_point(b, p).1 <= ON_OUTLINE)
    }

    /// The occluding building `p` lies in or on, if any.
    fn occupant(&self, p: DVec2) -> Option<usize> {
        (0..self.buildings.len()).find(|&i| self.buildings[i].occludes && self.holds(i, p))
    }

    /// `p`, or a free point within [`MAX_SNAP`] of it when `p` lies in
    /// occluding buildings: just outside the nearest outline, stepping out
    /// of each building in turn, or, where buildings touch and stepping out
    /// of one steps into the other, the first free point on rings around
    /// `p` (nearest ring first). Otherwise the building `p` lies in and its
    /// depth there.
    fn free_position(&self, p: DVec2) -> Result<DVec2, (u32, f64)> {
        let Some(first) = self.occupant(p) else {
            return Ok(p);
        };
        let (_, first_depth, _) = nearest_outline_point(&self.buildings[first], p);
        let refused = Err((first as u32, first_depth));
        if first_depth > MAX_SNAP {
            return refused;
        }
        // Every point tried below lies within MAX_SNAP (and a clearance) of
        // `p`, so only the occluding buildings whose bounds meet that square
        // can hold it.
        let reach = Rect {
            min: p - DVec2::splat(MAX_SNAP + SNAP_CLEARANCE),
            max: p + DVec2::splat(MAX_SNAP + SNAP_CLEARANCE),
        };
        let near: Vec<usize> = (0..self.buildings.len())
            .filter(|&i| self.buildings[i].occludes && self.bounds[i].intersects(&reach))
            .collect();
        let occupant_near = |q: DVec2| near.iter().copied().find(|&i| self.holds(i, q));
        let mut q = p;
        for _ in 0..4 {
            let Some(b) = occupant_near(q) else {
                return Ok(q);
            };
            let (foot, depth, outward) = nearest_outline_point(&self.buildings[b], q);
            if q.distance(p) + depth > MAX_SNAP {
                break;
            }
            q = foot + outward * SNAP_CLEARANCE;
        }
        for ring in 1..=FREE_RINGS {
            let radius = MAX_SNAP * ring as f64 / FREE_RINGS as f64;
            for k in 0..FREE_DIRECTIONS {
                let angle = std::f64::consts::TAU * k as f64 / FREE_DIRECTIONS as f64;
                let c = p + radius * DVec2::from_angle(angle);
                if occupant_near(c).is_none() {
                    return Ok(c);
                }
            }
        }
        refused
    }

    /// Every vertex and crossing point as (azimuth, distance) plus the fan
    /// into `scratch.directions` (ascending by azimuth, one entry per
    /// azimuth with the least distance), and every building into
    /// `scratch.beyond`.
    fn collect_directions(&self, origin: DVec2, scratch: &mut Scratch) {
        let dirs = &mut scratch.directions;
        dirs.clear();
        scratch.beyond.clear();
        let mut vertices = self.vertices.iter().peekable();
        while let Some(&&(_, b)) = vertices.peek() {
            scratch.building_azimuths.clear();
            let mut farthest: f64 = 0.0;
            while let Some(&(v, _)) = vertices.next_if(|&&(_, c)| c == b) {
                let d = v - origin;
                let d2 = d.length_squared();
                let azimuth = (d2 > 1e-24).then(|| d.y.atan2(d.x));
                if let Some(a) = azimuth {
                    dirs.push((a, d2.sqrt()));
                }
                scratch.building_azimuths.push(azimuth);
                farthest = farthest.max(d2);
            }
            scratch.beyond.add(
                scratch.building_azimuths.iter().copied(),
                farthest.sqrt(),
                self.buildings[b as usize].height,
            );
        }
        scratch.beyond.finish();
        for &v in &self.overlaps {
            let d = v - origin;
            let d2 = d.length_squared();
            if d2 > 1e-24 {
                dirs.push((d.y.atan2(d.x), d2.sqrt()));
            }
        }
        dirs.extend((0..FAN_DIRECTIONS).map(|k| {
            let a =
                -std::f64::consts::PI + std::f64::consts::TAU * k as f64 / FAN_DIRECTIONS as f64;
            (a, 0.0)
        }));
        sort_in_buckets(
            dirs,
            |d| d.0,
            (-std::f64::consts::PI, std::f64::consts::PI),
            &mut scratch.by_bucket,
        );
        dirs.dedup_by(|later, kept| {
            let same = later.0 == kept.0;
            if same {
                kept.1 = kept.1.min(later.1);
            }
            same
        });
    }

    /// Walk the wedge's middle ray and judge every building on it over the
    /// whole wedge, crossing by crossing. Returns how far from the origin
    /// the judged part of the wedge reaches: the farthest point, within the
    /// wedge, of the edge where the walk stopped (infinity if it ran to the
    /// end). The verdicts hold if no vertex lies inside the wedge that near.
    fn judge_wedge(&self, wedge: &Wedge, beyond: &HeightsBeyond, scratch: &mut Scratch) -> f64 {
        let Scratch {
            ray,
            envelope,
            seen,
            open,
            ties,
            ..
        } = scratch;
        let mut stopped_at = None;
        self.grid
            .walk(wedge.origin, wedge.mid, ray, |batch: &[Crossing]| {
                let mut rest = batch;
                while !rest.is_empty() {
                    // Crossings at the same distance (collinear edges of
                    // buildings that share a wall or overlap) touch, so none
                    // of them hides another: the buildings left go first,
                    // then those entered, lowest first, so that a lower
                    // building entered at the foot of a taller one's wall
                    // is judged there before the taller one raises the
                    // horizon or buries it (docs/verify.md, "Crossings at
                    // one distance").
                    let mut n = 1;
                    while n < rest.len() && rest[n].t - rest[n - 1].t <= TIE * rest[n].t {
                        n += 1;
                    }
                    let (group, after) = rest.split_at(n);
                    rest = after;
                    let group = if n == 1 {
                        group
                    } else {
                        let key = |c: &Crossing| match open.iter().any(|o| o.0 == c.building) {
                            true => (false, f64::NEG_INFINITY),
                            false => (true, self.buildings[c.building as usize].height),
                        };
                        ties.clear();
                        ties.extend_from_slice(group);
                        ties.sort_by(|a, b| {
                            let (ka, kb) = (key(a), key(b));
                            ka.0.cmp(&kb.0)
                                .then(ka.1.total_cmp(&kb.1))
                                .then(a.edge.cmp(&b.edge))
                        });
                        &ties[..]
                    };
                    for c in group {
                        match open.iter().position(|o| o.0 == c.building) {
                            None => self.enter(wedge, c, open, envelope, seen),
                            Some(i) => {
                                let (b, near) = open.swap_remove(i);
                                if near.is_some() {
                                    self.leave(wedge, b, c.edge, open, envelope, seen);
                                }
                            }
                        }
                    }
                }
                let last = batch.last().map(|c| c.edge);
                let done = self.nothing_more_to_see(wedge, last, envelope, beyond);
                if done {
                    stopped_at = last;
                }
                !done
            });
        match stopped_at {
            Some(edge) => self.farthest_in_wedge(wedge, edge),
            None => f64::INFINITY,
        }
    }

    /// A bound on the distance from the origin of every point of the wedge
    /// nearer than `edge` along its ray. When the edge crosses both borders
    /// (the wedge is under 180 degrees, so the part between the crossings
    /// lies inside it), distance along the segment peaks at an end: the
    /// farther crossing. Otherwise an end of the edge lies inside the wedge
    /// and the farthest end bounds the edge's part in it; the walk crossed
    /// the edge, so that end must then cut the wedge, and does (it is no
    /// farther than the bound).
    fn farthest_in_wedge(&self, wedge: &Wedge, edge: u32) -> f64 {
        let e = &self.grid.edges[edge as usize];
        let along = e.b - e.a;
        let from_a = e.a - wedge.origin;
        let mut spans = true;
        let mut farthest: f64 = 0.0;
        let (a0, a1) = wedge.azimuths;
        // The unit directions of the borders, needed only for a wedge
        // whose walk stopped.
        for u in [
            DVec2::new(a0.cos(), a0.sin()),
            DVec2::new(a1.cos(), a1.sin()),
        ] {
            let across = u.perp_dot(along);
            // The border ray origin + t u meets the edge at a + lambda along.
            let t = from_a.perp_dot(along) / across;
            let lambda = from_a.perp_dot(u) / across;
            if t.is_finite() && t > 0.0 && (0.0..=1.0).contains(&lambda) {
                farthest = farthest.max(t);
            } else {
                spans = false;
            }
        }
        if !spans {
            farthest = farthest
                .max(from_a.length())
                .max((e.b - wedge.origin).length());
        }
        // Room for the roundings of the distances compared with it.
        farthest * (1.0 + 1e-9) + 1e-9
    }

    /// The ray enters building `c.building` through edge `c.edge`.
    ///
    /// A building at least as high as the eye is seen, if at all, at the top
    /// of the wall it is entered by; it is judged here, then raises the
    /// horizon (its wall top is the worse end for every sight line beyond).
    /// A lower building still open here whose roof runs into this taller
    /// one is judged at the foot of this wall on its roof (the far end of
    /// that stretch of roof).
    fn enter(
        &self,
        wedge: &Wedge,
        c: &Crossing,
        open: &mut Vec<(u32, Option<u32>)>,
        envelope: &mut Envelope,
        seen: &mut Marks,
    ) {
        let b = &self.buildings[c.building as usize];
        if b.occludes {
            for k in 0..open.len() {
                let target = open[k].0;
                let t = &self.buildings[target as usize];
                if open[k].1.is_some()
                    && !seen.is_seen(target)
                    && t.height < wedge.z
                    && t.height < b.height
                {
                    self.judge_roof_point(wedge, target, c.edge, open, envelope, seen);
                }
            }
        }
        let dh = b.height - wedge.z;
        if dh >= 0.0 {
            let line = wedge.elevation(&self.grid, c.edge, dh);
            self.judge(wedge, c.building, c.edge, &line, envelope, seen);
            if b.occludes {
                envelope.insert(line);
            }
        }
        open.push((c.building, Some(c.edge)));
    }

    /// The ray leaves `building` through edge `far` (already removed from
    /// `open`). A building lower than the eye is seen, if at all, at the far
    /// end of its roof; judged here, then it raises the horizon.
    fn leave(
        &self,
        wedge: &Wedge,
        building: u32,
        far: u32,
        open: &[(u32, Option<u32>)],
        envelope: &mut Envelope,
        seen: &mut Marks,
    ) {
        let b = &self.buildings[building as usize];
        let dh = b.height - wedge.z;
        if dh < 0.0 {
            if !seen.is_seen(building) {
                self.judge_roof_point(wedge, building, far, open, envelope, seen);
            }
            if b.occludes {
                envelope.insert(wedge.elevation(&self.grid, far, dh));
            }
        }
    }

    /// Judge the roof of `target` (lower than the eye) at the ray's crossing
    /// with `edge`: hidden there if that point lies inside a higher
    /// occluding building the ray is in (overlapping footprints), otherwise
    /// seen if it rises above the horizon somewhere in the wedge.
    fn judge_roof_point(
        &self,
        wedge: &Wedge,
        target: u32,
        edge: u32,
        open: &[(u32, Option<u32>)],
        envelope: &Envelope,
        seen: &mut Marks,
    ) {
        let h = self.buildings[target as usize].height;
        let buried = open.iter().any(|&(j, near)| {
            let o = &self.buildings[j as usize];
            j != target && near.is_some() && o.occludes && o.height > h
        });
        if !buried {
            let line = wedge.elevation(&self.grid, edge, h - wedge.z);
            self.judge(wedge, target, edge, &line, envelope, seen);
        }
    }

    /// Mark `building` seen if its elevation `line` (of a point on `edge`)
    /// reaches the horizon somewhere in the wedge.
    fn judge(
        &self,
        wedge: &Wedge,
        building: u32,
        edge: u32,
        line: &Line,
        envelope: &Envelope,
        seen: &mut Marks,
    ) {
        if seen.is_seen(building) {
            return;
        }
        let (s, margin) = envelope.best_against(line);
        if margin >= 0.0 {
            let h = self.buildings[building as usize].height;
            seen.mark(building, wedge.point_on(&self.grid, edge, s, h));
        }
    }

    /// True when the horizon already hides everything the rest of the wedge
    /// can hold: every point still to be judged lies beyond the last edge
    /// crossed, on a building reaching at least that far, and is
    /// no higher than the highest such building.
    fn nothing_more_to_see(
        &self,
        wedge: &Wedge,
        last: Option<u32>,
        envelope: &Envelope,
        beyond: &HeightsBeyond,
    ) -> bool {
        let Some(last) = last else {
            return false;
        };
        if envelope.is_empty() {
            return false;
        }
        let edge = &self.grid.edges[last as usize];
        // Every ray of the wedge crosses the edge itself, so what lies
        // beyond is at least as far as the nearest point of the edge.
        let nearest = distance_to_segment(wedge.origin, edge.a, edge.b);
        let (from, to) = wedge.azimuths;
        let Some(highest) = beyond.highest(from, to, nearest) else {
            return true;
        };
        let dh = highest - wedge.z;
        if dh <= 0.0 {
            return envelope.strictly_above(&Line {
                at0: 0.0,
                slope: 0.0,
            });
        }
        envelope.strictly_above(&wedge.elevation(&self.grid, last, dh))
    }
}
