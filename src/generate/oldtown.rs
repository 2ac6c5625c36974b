//! The "old-town" style of generated city: perimeter blocks made of
//! separate wall-sharing buildings whose shared walls are drawn the way
//! real map data draws them: gaps and overlaps of 1 mm to 20 cm between
//! neighbours, facades that do not quite line up, extra vertices on one side
//! of a shared wall only, narrow passages into the yards (some wider than a
//! person, some not) and small light wells.
//!
//! Uses the same street plan as the default style ([`super::layout`]); only
//! the filling of the blocks differs. Deterministic per seed: each block
//! draws from its own ChaCha8 stream.

use glam::DVec2;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::layout::GridRect;
use super::layout::cuts;
use super::{GenerateParams, GeneratedCity, Kind, fill_plan, to_local};
use crate::model::{Polygon, ring_signed_area2};

/// Depth of the perimeter rows from the street, metres.
const DEPTH: (f64, f64) = (10.0, 16.0);
/// Width of one building along the street, metres.
const WIDTH: (f64, f64) = (6.0, 15.0);
/// Chance that a shared wall is drawn exactly the same in both buildings.
const EXACT_WALL_CHANCE: f64 = 0.25;
/// Gaps and overlaps between neighbours: 1 mm to 20 cm (log-uniform).
const MISALIGN: (f64, f64) = (0.001, 0.2);
/// Facade and back lines of neighbours are off by up to this, metres.
const LINE_JITTER: (f64, f64) = (0.001, 0.05);
/// Chance of an extra vertex on one side of a shared wall only.
const EXTRA_VERTEX_CHANCE: f64 = 0.4;
/// Chance that a shared wall (not at a corner) is a passage into the yard,
/// and the chance that a passage is narrower than half a metre.
const PASSAGE_CHANCE: f64 = 0.12;
const NARROW_PASSAGE_CHANCE: f64 = 0.35;
const NARROW_PASSAGE: (f64, f64) = (0.15, 0.45);
const WIDE_PASSAGE: (f64, f64) = (0.7, 3.0);
/// Chance of a light well in a building at least 8 m wide and 12 m deep;
/// the chance that it is narrower than half a metre.
const LIGHT_WELL_CHANCE: f64 = 0.2;
const NARROW_WELL_CHANCE: f64 = 0.3;

/// A building in the grid frame: exterior and holes, any orientation.
struct Drawn {
    exterior: Vec<(f64, f64)>,
    holes: Vec<Vec<(f64, f64)>>,
    height: f64,
}

/// The old-town city: exactly `params.buildings` buildings, kind `row`.
pub fn generate_old_town(params: &GenerateParams) -> GeneratedCity {
    fill_plan(params, 0.8, |rng, rect| {
        fill_block(rng, rect)
            .iter()
            .map(|b| (Kind::Row, b.height, to_polygon(b)))
            .collect()
    })
}

fn to_polygon(b: &Drawn) -> Polygon {
    let ring = |pts: &[(f64, f64)], ccw: bool| {
        let mut r: Vec<DVec2> = pts.iter().map(|&(u, v)| to_local(u, v)).collect();
        if (ring_signed_area2(&r) > 0.0) != ccw {
            r.reverse();
        }
        r
    };
    Polygon {
        exterior: ring(&b.exterior, true),
        holes: b.holes.iter().map(|h| ring(h, false)).collect(),
    }
}

/// A value of random sign whose size is log-uniform in `range`.
fn signed_log(rng: &mut ChaCha8Rng, range: (f64, f64)) -> f64 {
    let size = (rng.random_range(range.0.ln()..range.1.ln())).exp();
    if rng.random_bool(0.5) { size } else { -size }
}

/// One end of a building along its row: where its side wall runs, at the
/// facade and at the back, with an optional extra vertex (depth fraction,
/// sideways offset).
#[derive(Clone, Copy)]
struct Side {
    front: f64,
    back: f64,
    extra: Option<(f64, f64)>,
}

impl Side {
    fn exact(at: f64) -> Side {
        Side {
            front: at,
            back: at,
            extra: None,
        }
    }
}

/// The two sides drawn for the wall at `at` between a left and a right
/// neighbour: exactly shared, misaligned (gap or overlap), or a passage.
fn wall(rng: &mut ChaCha8Rng, at: f64, passage_allowed: bool) -> (Side, Side) {
    if passage_allowed && rng.random_bool(PASSAGE_CHANCE) {
        let w = if rng.random_bool(NARROW_PASSAGE_CHANCE) {
            rng.random_range(NARROW_PASSAGE.0..NARROW_PASSAGE.1)
        } else {
            rng.random_range(WIDE_PASSAGE.0..WIDE_PASSAGE.1)
        };
        return (Side::exact(at - 0.5 * w), Side::exact(at + 0.5 * w));
    }
    let mut left = Side::exact(at);
    let mut right = Side::exact(at);
    if !rng.random_bool(EXACT_WALL_CHANCE) {
        // The right neighbour's wall is off by a gap (> 0) or overlap (< 0).
        let front = signed_log(rng, MISALIGN);
        let back = if rng.random_bool(0.5) {
            front
        } else {
            signed_log(rng, MISALIGN)
        };
        if rng.random_bool(0.5) {
            right.front += front;
            right.back += back;
        } else {
            left.front -= front;
            left.back -= back;
        }
    }
    if rng.random_bool(EXTRA_VERTEX_CHANCE) {
        let extra = (rng.random_range(0.2..0.8), signed_log(rng, (0.0005, 0.005)));
        if rng.random_bool(0.5) {
            left.extra = Some(extra);
        } else {
            right.extra = Some(extra);
        }
    }
    (left, right)
}

/// The buildings of one block: four perimeter rows around an open yard.
/// The south and north rows run the full width (their end buildings are
/// the corners); the west and east rows fit between them.
fn fill_block(rng: &mut ChaCha8Rng, b: GridRect) -> Vec<Drawn> {
    let mut depth = || rng.random_range(DEPTH.0..=DEPTH.1);
    let (ds, dn, dw, de) = (depth(), depth(), depth(), depth());
    let storeys = (3u32, 6u32);
    let mut out = Vec::new();
    // Each row: positions along it and a map (s, t) -> (u, v), t = 0 at the
    // facade, t = row depth at the back.
    type Map = Box<dyn Fn(f64, f64) -> (f64, f64)>;
    let rows: [(Vec<f64>, f64, Map, bool); 4] = [
        (
            {
                let mut c = vec![b.u0];
                c.extend(cuts(rng, b.u0 + dw, b.u1 - de, WIDTH));
                c.push(b.u1);
                c
            },
            ds,
            Box::new(move |s, t| (s, b.v0 + t)),
            true,
        ),
        (
            {
                let mut c = vec![b.u0];
                c.extend(cuts(rng, b.u0 + dw, b.u1 - de, WIDTH));
                c.push(b.u1);
                c
            },
            dn,
            Box::new(move |s, t| (s, b.v1 - t)),
            true,
        ),
        (
            cuts(rng, b.v0 + ds, b.v1 - dn, WIDTH),
            dw,
            Box::new(move |s, t| (b.u0 + t, s)),
            false,
        ),
        (
            cuts(rng, b.v0 + ds, b.v1 - dn, WIDTH),
            de,
            Box::new(move |s, t| (b.u1 - t, s)),
            false,
        ),
    ];
    for (positions, d, map, full) in rows.iter() {
        let k = positions.len();
        // Sides of every wall; the ends of a west/east row abut the corner
        // buildings' side walls (drawn misaligned too, never passages).
        let mut walls: Vec<(Side, Side)> = Vec::with_capacity(k);
        for (i, &at) in positions.iter().enumerate() {
            let end = i == 0 || i + 1 == k;
            if end && *full {
                walls.push((Side::exact(at), Side::exact(at)));
            } else {
                let corner = *full && (i == 1 || i + 2 == k);
                walls.push(wall(rng, at, !end && !corner));
            }
        }
        for i in 0..k - 1 {
            let (left, right) = (walls[i].1, walls[i + 1].0);
            let front = signed_log(rng, LINE_JITTER) * f64::from(rng.random_bool(0.6) as u8);
            let back = *d + signed_log(rng, LINE_JITTER) * f64::from(rng.random_bool(0.6) as u8);
            // Corner buildings of the full rows reach the full depth of the
            // crossing row along their side; they keep their own depth here.
            let mut ring: Vec<(f64, f64)> = Vec::new();
            ring.push(map(left.front, front));
            ring.push(map(right.front, front));
            if let Some((f, off)) = right.extra {
                let t = front + f * (back - front);
                let s = right.front + f * (right.back - right.front) + off;
                ring.push(map(s, t));
            }
            ring.push(map(right.back, back));
            ring.push(map(left.back, back));
            if let Some((f, off)) = left.extra {
                let t = back - f * (back - front);
                let s = left.back + f * (left.front - left.back) + off;
                ring.push(map(s, t));
            }
            let width = (right.front - left.front).min(right.back - left.back);
            let mut holes = Vec::new();
            if width >= 8.0 && *d >= 12.0 && rng.random_bool(LIGHT_WELL_CHANCE) {
                let (ws, wt) = if rng.random_bool(NARROW_WELL_CHANCE) {
                    (rng.random_range(0.25..0.45), rng.random_range(1.0..3.0))
                } else {
                    (rng.random_range(1.5..4.0), rng.random_range(1.5..4.0))
                };
                let cs = 0.5 * (left.front + right.front);
                let ct = 0.5 * *d;
                holes.push(vec![
                    map(cs - 0.5 * ws, ct - 0.5 * wt),
                    map(cs + 0.5 * ws, ct - 0.5 * wt),
                    map(cs + 0.5 * ws, ct + 0.5 * wt),
                    map(cs - 0.5 * ws, ct + 0.5 * wt),
                ]);
            }
            let storey_count = rng.random_range(storeys.0..=storeys.1) as f64;
            let height = ((storey_count * 3.0 + rng.random_range(0.0..2.5)) * 10.0).round() / 10.0;
            out.push(Drawn {
                exterior: ring,
                holes,
                height,
            });
        }
    }
    out
}
