//! Sample points on the cells' top edges (docs/METHOD.md §3 and §4): every distinct
//! cell vertex, and points along every distinct cell edge at a spacing of at
//! most 2 * eps. Cells that share an edge or a vertex share its samples, so
//! each is computed once.

use std::collections::HashMap;

use glam::DVec2;

use crate::model::{cut_points, piece_count};

/// The distinct vertices and edges of a triangle mesh, and which of them
/// bound each cell.
#[derive(Clone, Debug)]
pub struct MeshTopology {
    pub vertices: Vec<DVec2>,
    /// Pairs of vertex indices, lower index first.
    pub edges: Vec<[u32; 2]>,
    /// Per cell: its three vertices and its three edges.
    pub cell_vertices: Vec<[u32; 3]>,
    pub cell_edges: Vec<[u32; 3]>,
}

impl MeshTopology {
    /// Find shared vertices (bit-identical coordinates) and edges. Indices are
    /// assigned in order of first appearance, so the result is deterministic.
    pub fn of(triangles: &[[DVec2; 3]]) -> MeshTopology {
        let mut vertex_index: HashMap<(u64, u64), u32> = HashMap::new();
        let mut edge_index: HashMap<[u32; 2], u32> = HashMap::new();
        let mut topo = MeshTopology {
            vertices: Vec::new(),
            edges: Vec::new(),
            cell_vertices: Vec::new(),
            cell_edges: Vec::new(),
        };
        for t in triangles {
            let mut vs = [0u32; 3];
            for (k, p) in t.iter().enumerate() {
                let key = (p.x.to_bits(), p.y.to_bits());
                let next = topo.vertices.len() as u32;
                vs[k] = *vertex_index.entry(key).or_insert_with(|| {
                    topo.vertices.push(*p);
                    next
                });
            }
            let mut es = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (vs[k], vs[(k + 1) % 3]);
                let key = [a.min(b), a.max(b)];
                let next = topo.edges.len() as u32;
                es[k] = *edge_index.entry(key).or_insert_with(|| {
                    topo.edges.push(key);
                    next
                });
            }
            topo.cell_vertices.push(vs);
            topo.cell_edges.push(es);
        }
        topo
    }

    /// The points strictly inside edge `e`, spaced so that consecutive
    /// samples (end points included) are at most `max_spacing` apart.
    pub fn edge_interior_samples(&self, e: usize, max_spacing: f64) -> Vec<DVec2> {
        let [a, b] = self.edges[e];
        interior_samples(
            self.vertices[a as usize],
            self.vertices[b as usize],
            max_spacing,
        )
    }
}

/// Points strictly between `a` and `b` such that, with `a` and `b`, no two
/// consecutive points are more than `max_spacing` apart.
pub fn interior_samples(a: DVec2, b: DVec2, max_spacing: f64) -> Vec<DVec2> {
    let pieces = piece_count(a, b, max_spacing);
    cut_points(a, b, pieces).skip(1).take(pieces - 1).collect()
}

/// The sample points of one cell's top edges, seen from above: each corner
/// followed by the points along the edge that starts there.
pub fn cell_sample_points(t: &[DVec2; 3], max_spacing: f64) -> Vec<DVec2> {
    let mut out = Vec::new();
    for k in 0..3 {
        let (a, b) = (t[k], t[(k + 1) % 3]);
        out.push(a);
        out.extend(interior_samples(a, b, max_spacing));
    }
    out
}

/// How many points [`interior_samples`] gives.
pub fn interior_sample_count(a: DVec2, b: DVec2, max_spacing: f64) -> usize {
    piece_count(a, b, max_spacing) - 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shared_edges_and_spacing() {
        let p = [
            DVec2::new(0.0, 0.0),
            DVec2::new(10.0, 0.0),
            DVec2::new(0.0, 10.0),
            DVec2::new(10.0, 10.0),
        ];
        let topo = MeshTopology::of(&[[p[0], p[1], p[2]], [p[1], p[3], p[2]]]);
        assert_eq!(topo.vertices.len(), 4);
        assert_eq!(topo.edges.len(), 5);
        let diag = topo.cell_edges[0]
            .iter()
            .find(|e| topo.cell_edges[1].contains(e));
        assert!(diag.is_some(), "the diagonal is shared");
        let samples = interior_samples(p[0], p[1], 2.0);
        let mut all = vec![p[0]];
        all.extend(samples);
        all.push(p[1]);
        assert!(all.windows(2).all(|w| w[0].distance(w[1]) <= 2.0 + 1e-12));
        assert_eq!(all.len(), 6);
    }
}
