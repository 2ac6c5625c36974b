//! The cells' mesh in a file (docs/FORMAT.md, "Vertices" and "Triangles"):
//! vertices on the 1/256 m grid, in order of first use, each coordinate
//! coded as the difference of its grid number from the previous vertex's;
//! corners as "a new vertex", "the vertex at position m of the recently used
//! ones" or "the vertex k back in order of first use", all range coded. Each
//! section is padded with zero bytes to the least length the reader accepts
//! for its count (which bounds what a hostile count can make the reader
//! allocate). Also owns the grid itself ([`GRID`], [`snap`]): the bake puts
//! every cell corner on it before it samples the cells.

use glam::DVec2;

use super::rc::{BitCoder, Decoder, Encoder, NumberModel, PROB_INIT, Prob};

/// Cell corners lie on the grid of this spacing in local metres (1/256 m).
pub const GRID: f64 = 1.0 / 256.0;
/// Grid numbers per metre.
pub(super) const PER_METRE: f64 = 256.0;
/// Largest grid number a coordinate may have: 2^52 (about 1.8e13 m).
pub(super) const MAX_GRID_NUMBER: i64 = 1 << 52;
/// The greatest distance a corner moves when put on the grid: half the
/// diagonal of a grid square.
pub const SNAP_DISTANCE: f64 = GRID * std::f64::consts::FRAC_1_SQRT_2;

/// The nearest grid point (ties away from zero), or `None` when a
/// coordinate is not finite or too large for the grid.
pub fn snap(p: DVec2) -> Option<DVec2> {
    let one = |v: f64| {
        let g = (v * PER_METRE).round();
        // `+ 0.0` makes -0 the same point as 0.
        (g.is_finite() && g.abs() <= MAX_GRID_NUMBER as f64).then_some(g / PER_METRE + 0.0)
    };
    Some(DVec2::new(one(p.x)?, one(p.y)?))
}

/// The grid numbers of a point on the grid, or `None` when it is off it.
pub fn grid_numbers(p: DVec2) -> Option<(i64, i64)> {
    let one = |v: f64| {
        let g = v * PER_METRE;
        (g.is_finite() && g.fract() == 0.0 && g.abs() <= MAX_GRID_NUMBER as f64).then_some(g as i64)
    };
    Some((one(p.x)?, one(p.y)?))
}

/// Recently used vertices a corner can name by position (the window of
/// the triangles' coding); position `WINDOW - 1` is the escape to "k back".
const WINDOW: usize = 64;
const WINDOW_BITS: u32 = 6;

/// Least bytes of the vertices section per vertex, and of the triangles
/// section per cell.
pub const VERTEX_MIN_BYTES: u64 = 2;
pub const CELL_MIN_BYTES: u64 = 1;

/// A signed difference as an unsigned number: 0, -1, 1, -2, ... as 0, 1, 2, 3, ...
pub(super) fn zigzag(d: i64) -> u64 {
    ((d << 1) ^ (d >> 63)) as u64
}

pub(super) fn unzigzag(z: u64) -> i64 {
    ((z >> 1) ^ (z & 1).wrapping_neg()) as i64
}

fn pad(mut bytes: Vec<u8>, least: u64) -> Vec<u8> {
    if (bytes.len() as u64) < least {
        bytes.resize(least as usize, 0);
    }
    bytes
}

/// The vertices (in order of first use) and the corner indices of the cells.
pub fn index_mesh(cells: &[[DVec2; 3]]) -> (Vec<DVec2>, Vec<[u32; 3]>) {
    let mut vertex_of = std::collections::HashMap::new();
    let mut vertices = Vec::new();
    let corners = cells
        .iter()
        .map(|tri| {
            tri.map(|p| {
                let next = vertices.len() as u32;
                let v = *vertex_of
                    .entry((p.x.to_bits(), p.y.to_bits()))
                    .or_insert(next);
                if v == next {
                    vertices.push(p);
                }
                v
            })
        })
        .collect();
    (vertices, corners)
}

/// The vertices section's bytes; every vertex must be on the grid (the
/// writer checks).
pub fn encode_vertices(vertices: &[(i64, i64)]) -> Vec<u8> {
    let mut rc = Encoder::new();
    let (mut mx, mut my) = (NumberModel::default(), NumberModel::default());
    let (mut px, mut py) = (0i64, 0i64);
    for &(x, y) in vertices {
        rc.number(&mut mx, zigzag(x - px));
        rc.number(&mut my, zigzag(y - py));
        (px, py) = (x, y);
    }
    pad(rc.finish(), VERTEX_MIN_BYTES * vertices.len() as u64)
}

/// The triangles section's bytes, for corners numbered in order of first use.
pub fn encode_triangles(corners: &[[u32; 3]]) -> Vec<u8> {
    let mut rc = Encoder::new();
    let mut coding = CornerCoding::new();
    for tri in corners {
        for (k, &v) in tri.iter().enumerate() {
            let _ = coding.corner(&mut rc, k, v);
        }
    }
    pad(rc.finish(), CELL_MIN_BYTES * corners.len() as u64)
}

/// The models and state of the corners' coding, written once for both
/// sides (docs/FORMAT.md, "Triangles").
struct CornerCoding {
    /// "Not a new vertex", context: corner 0, 1, 2 (x 2) and whether the
    /// previous corner of the cell was new (+1).
    new: [Prob; 6],
    /// Position in the window of recently used vertices, per corner.
    recent: [[Prob; WINDOW]; 3],
    /// The distance back in order of first use, less one, per corner.
    back: [NumberModel; 3],
    /// Vertices used so far.
    next: u64,
    /// Recently used vertices, most recent first, at most `WINDOW - 1`.
    window: Vec<u32>,
    previous_new: usize,
}

impl CornerCoding {
    fn new() -> Self {
        CornerCoding {
            new: [PROB_INIT; 6],
            recent: [[PROB_INIT; WINDOW]; 3],
            back: [
                NumberModel::default(),
                NumberModel::default(),
                NumberModel::default(),
            ],
            next: 0,
            window: Vec::with_capacity(WINDOW),
            previous_new: 0,
        }
    }

    /// Code corner `k` (0, 1, 2) of a cell, vertex `v` when encoding;
    /// returns the vertex (decoded, when decoding). Errors: the stream ends,
    /// or names a vertex before the first.
    fn corner<C: BitCoder>(&mut self, rc: &mut C, k: usize, v: u32) -> Result<u64, String> {
        let past = |_| "the corners' coding runs past the end of the triangles section".to_string();
        if k == 0 {
            self.previous_new = 0;
        }
        let is_new = u64::from(v) == self.next;
        let old = rc
            .code(&mut self.new[2 * k + self.previous_new], u32::from(!is_new))
            .map_err(past)?
            == 1;
        // The vertex, and its position in the window if it is there.
        let (index, found) = if !old {
            self.next += 1;
            (self.next - 1, None)
        } else {
            let at = self
                .window
                .iter()
                .position(|&w| w == v)
                .unwrap_or(WINDOW - 1);
            let at = rc
                .code_tree(&mut self.recent[k], WINDOW_BITS, at as u32)
                .map_err(past)? as usize;
            if at < WINDOW - 1 {
                match self.window.get(at) {
                    Some(&w) => (u64::from(w), Some(at)),
                    None => return Err("a corner names a recent vertex that is not there".into()),
                }
            } else {
                let back = rc
                    .number_of(
                        &mut self.back[k],
                        self.next.wrapping_sub(u64::from(v)).wrapping_sub(1),
                    )
                    .map_err(past)?
                    .and_then(|b| b.checked_add(1))
                    .filter(|&b| b <= self.next)
                    .ok_or("a corner refers to a vertex before the first")?;
                let index = self.next - back;
                // A writer escapes only vertices outside the window; a
                // hostile stream may name one inside it.
                let found = self.window.iter().position(|&w| u64::from(w) == index);
                (index, found)
            }
        };
        self.previous_new = usize::from(!old);
        // Move (or put) the vertex to the front of the window.
        if index <= u64::from(u32::MAX) {
            match found {
                Some(at) => {
                    self.window.remove(at);
                }
                None if self.window.len() == WINDOW - 1 => {
                    self.window.pop();
                }
                None => {}
            }
            self.window.insert(0, index as u32);
        }
        Ok(index)
    }
}

/// Bytes left after a stream must be zero padding.
fn check_padding(bytes: &[u8], pos: usize, section: &str) -> Result<(), String> {
    if bytes[pos..].iter().any(|&b| b != 0) {
        return Err(format!(
            "the {section} section has {} bytes after its coding that are not zero padding",
            bytes.len() - pos
        ));
    }
    Ok(())
}

/// Decode `count` vertices (the caller has checked `count` against the
/// section's length): local metres, on the grid.
pub fn decode_vertices(bytes: &[u8], count: u32) -> Result<Vec<DVec2>, String> {
    let past = |_| "the vertices' coding runs past the end of the vertices section".to_string();
    let mut rc = Decoder::new(bytes)?;
    let (mut mx, mut my) = (NumberModel::default(), NumberModel::default());
    let (mut px, mut py) = (0i64, 0i64);
    let mut out = Vec::with_capacity(count as usize);
    for k in 0..count {
        let mut coordinate = |m: &mut NumberModel, prev: i64| -> Result<i64, String> {
            let z = rc
                .number(m)
                .map_err(past)?
                .ok_or_else(|| format!("vertex {k}: a coordinate difference over 64 bits"))?;
            prev.checked_add(unzigzag(z))
                .filter(|g| g.abs() <= MAX_GRID_NUMBER)
                .ok_or_else(|| format!("vertex {k}: a coordinate beyond 2^52 grid steps"))
        };
        px = coordinate(&mut mx, px)?;
        py = coordinate(&mut my, py)?;
        out.push(DVec2::new(px as f64 / PER_METRE, py as f64 / PER_METRE));
    }
    check_padding(bytes, rc.pos(), "vertices")?;
    Ok(out)
}

/// Decode the corners of `cells` cells over `vertex_count` vertices (the
/// caller has checked `cells` against the section's length); every vertex
/// must be used.
pub fn decode_triangles(
    bytes: &[u8],
    cells: u32,
    vertex_count: u32,
) -> Result<Vec<[u32; 3]>, String> {
    let mut rc = Decoder::new(bytes)?;
    let mut coding = CornerCoding::new();
    let mut out = Vec::with_capacity(cells as usize);
    for c in 0..cells {
        let mut tri = [0u32; 3];
        for (k, corner) in tri.iter_mut().enumerate() {
            let index = coding
                .corner(&mut rc, k, 0)
                .map_err(|e| format!("cell {c}: {e}"))?;
            if index >= u64::from(vertex_count) {
                return Err(format!(
                    "cell {c} uses vertex {index}, but there are {vertex_count}"
                ));
            }
            *corner = index as u32;
        }
        out.push(tri);
    }
    check_padding(bytes, rc.pos(), "triangles")?;
    if coding.next != u64::from(vertex_count) {
        return Err(format!(
            "the cells use {} of the {vertex_count} vertices",
            coding.next
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn zigzag_round_trips() {
        for d in [0i64, 1, -1, i64::MAX, i64::MIN, 12345, -7] {
            assert_eq!(unzigzag(zigzag(d)), d);
        }
        assert_eq!(zigzag(-1), 1);
        assert_eq!(zigzag(1), 2);
    }

    proptest! {
        #[test]
        fn mesh_round_trips(
            points in proptest::collection::vec((-1e4f64..1e4, -1e4f64..1e4), 1..90),
            picks in proptest::collection::vec((any::<u16>(), any::<u16>(), any::<u16>()), 0..60),
        ) {
            let p: Vec<DVec2> = points.iter().map(|&(x, y)| snap(DVec2::new(x, y)).unwrap()).collect();
            let cells: Vec<[DVec2; 3]> = picks
                .iter()
                .map(|&(a, b, c)| [a, b, c].map(|i| p[i as usize % p.len()]))
                .collect();
            let (vertices, corners) = index_mesh(&cells);
            let numbers: Vec<(i64, i64)> = vertices.iter().map(|&v| grid_numbers(v).unwrap()).collect();
            let vb = encode_vertices(&numbers);
            let tb = encode_triangles(&corners);
            prop_assert!(vb.len() as u64 >= VERTEX_MIN_BYTES * vertices.len() as u64);
            prop_assert!(tb.len() as u64 >= CELL_MIN_BYTES * corners.len() as u64);
            let back = decode_vertices(&vb, vertices.len() as u32).unwrap();
            prop_assert_eq!(
                back.iter().map(|v| (v.x.to_bits(), v.y.to_bits())).collect::<Vec<_>>(),
                vertices.iter().map(|v| (v.x.to_bits(), v.y.to_bits())).collect::<Vec<_>>()
            );
            let tri = decode_triangles(&tb, corners.len() as u32, vertices.len() as u32).unwrap();
            prop_assert_eq!(tri, corners);
        }
    }
}
