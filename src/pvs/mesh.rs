//! The cells' mesh in a version 2 file (docs/FORMAT.md, "Vertices" and
//! "Triangles"): exact f64 vertices in order of first use, each coordinate
//! coded losslessly as the difference of its bit pattern from the previous
//! vertex's, and the corners as "a new vertex" or "the vertex k back", both
//! range coded. Each section is padded with zero bytes to the least length
//! the reader accepts for its count (which bounds what a hostile count can
//! make the reader allocate).

use glam::DVec2;

use super::rc::{Decoder, Encoder, NumberModel, PROB_INIT, Prob};

/// Least bytes of the vertices section per vertex, and of the triangles
/// section per cell.
pub const VERTEX_MIN_BYTES: u64 = 2;
pub const CELL_MIN_BYTES: u64 = 1;

fn zigzag(d: u64) -> u64 {
    (d << 1) ^ (((d as i64) >> 63) as u64)
}

fn unzigzag(z: u64) -> u64 {
    (z >> 1) ^ (z & 1).wrapping_neg()
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

/// The vertices section's bytes.
pub fn encode_vertices(vertices: &[DVec2]) -> Vec<u8> {
    let mut rc = Encoder::new();
    let (mut mx, mut my) = (NumberModel::default(), NumberModel::default());
    let (mut px, mut py) = (0u64, 0u64);
    for p in vertices {
        let (x, y) = (p.x.to_bits(), p.y.to_bits());
        rc.number(&mut mx, zigzag(x.wrapping_sub(px)));
        rc.number(&mut my, zigzag(y.wrapping_sub(py)));
        (px, py) = (x, y);
    }
    pad(rc.finish(), VERTEX_MIN_BYTES * vertices.len() as u64)
}

/// The triangles section's bytes, for corners numbered in order of first use.
pub fn encode_triangles(corners: &[[u32; 3]]) -> Vec<u8> {
    let mut rc = Encoder::new();
    let mut models = TriangleModels::new();
    let mut next = 0u32;
    for tri in corners {
        let mut previous_new = 0;
        for (k, &v) in tri.iter().enumerate() {
            let is_new = v == next;
            rc.bit(&mut models.new[2 * k + previous_new], u32::from(!is_new));
            if is_new {
                next += 1;
            } else {
                rc.number(&mut models.back[k], u64::from(next - v - 1));
            }
            previous_new = usize::from(is_new);
        }
    }
    pad(rc.finish(), CELL_MIN_BYTES * corners.len() as u64)
}

struct TriangleModels {
    /// "Not a new vertex", context: corner 0, 1, 2 (x 2) and whether the
    /// previous corner of the cell was new (+1).
    new: [Prob; 6],
    /// The distance back, less one, per corner position.
    back: [NumberModel; 3],
}

impl TriangleModels {
    fn new() -> Self {
        TriangleModels {
            new: [PROB_INIT; 6],
            back: [
                NumberModel::default(),
                NumberModel::default(),
                NumberModel::default(),
            ],
        }
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
/// section's length).
pub fn decode_vertices(bytes: &[u8], count: u32) -> Result<Vec<DVec2>, String> {
    let past = |_| "the vertices' coding runs past the end of the vertices section".to_string();
    let mut rc = Decoder::new(bytes)?;
    let (mut mx, mut my) = (NumberModel::default(), NumberModel::default());
    let (mut px, mut py) = (0u64, 0u64);
    let mut out = Vec::with_capacity(count as usize);
    for k in 0..count {
        let mut coordinate = |m: &mut NumberModel, prev: u64| -> Result<u64, String> {
            let z = rc
                .number(m)
                .map_err(past)?
                .ok_or_else(|| format!("vertex {k}: a coordinate difference over 64 bits"))?;
            Ok(prev.wrapping_add(unzigzag(z)))
        };
        px = coordinate(&mut mx, px)?;
        py = coordinate(&mut my, py)?;
        let p = DVec2::new(f64::from_bits(px), f64::from_bits(py));
        if !p.is_finite() {
            return Err(format!("vertex {k} has a non-finite coordinate"));
        }
        out.push(p);
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
    let past = |_| "the corners' coding runs past the end of the triangles section".to_string();
    let mut rc = Decoder::new(bytes)?;
    let mut models = TriangleModels::new();
    let mut next = 0u64;
    let mut out = Vec::with_capacity(cells as usize);
    for c in 0..cells {
        let mut tri = [0u32; 3];
        let mut previous_new = 0;
        for (k, corner) in tri.iter_mut().enumerate() {
            let old = rc
                .bit(&mut models.new[2 * k + previous_new])
                .map_err(past)?
                == 1;
            let index = if old {
                let back = rc
                    .number(&mut models.back[k])
                    .map_err(past)?
                    .and_then(|b| b.checked_add(1))
                    .filter(|&b| b <= next)
                    .ok_or_else(|| format!("cell {c} refers to a vertex before the first"))?;
                next - back
            } else {
                next += 1;
                next - 1
            };
            if index >= u64::from(vertex_count) {
                return Err(format!(
                    "cell {c} uses vertex {index}, but there are {vertex_count}"
                ));
            }
            *corner = index as u32;
            previous_new = usize::from(!old);
        }
        out.push(tri);
    }
    check_padding(bytes, rc.pos(), "triangles")?;
    if next != u64::from(vertex_count) {
        return Err(format!(
            "the cells use {next} of the {vertex_count} vertices"
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
        for d in [0u64, 1, u64::MAX, 1 << 63, 12345, (-7i64) as u64] {
            assert_eq!(unzigzag(zigzag(d)), d);
        }
        assert_eq!(zigzag((-1i64) as u64), 1);
        assert_eq!(zigzag(1), 2);
    }

    proptest! {
        #[test]
        fn mesh_round_trips(
            points in proptest::collection::vec((-1e4f64..1e4, -1e4f64..1e4), 1..40),
            picks in proptest::collection::vec((any::<u16>(), any::<u16>(), any::<u16>()), 0..60),
        ) {
            let p: Vec<DVec2> = points.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
            let cells: Vec<[DVec2; 3]> = picks
                .iter()
                .map(|&(a, b, c)| [a, b, c].map(|i| p[i as usize % p.len()]))
                .collect();
            let (vertices, corners) = index_mesh(&cells);
            let vb = encode_vertices(&vertices);
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
