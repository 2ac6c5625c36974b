//! Conforming longest-edge bisection (Rivara's LEPP): split triangles at the
//! midpoints of their longest edges, together with the neighbour across
//! that edge, until no edge is longer than the bound. It always
//! terminates, never leaves a vertex in the middle of a neighbour's edge,
//! and keeps the smallest angle at least half of what it was.

use std::collections::HashMap;

use glam::DVec2;

/// A triangle mesh: vertices and counter-clockwise index triples.
pub struct Mesh {
    pub vertices: Vec<DVec2>,
    pub triangles: Vec<[u32; 3]>,
}

/// The directed edge (from, to) -> the triangle that has it.
type EdgeMap = HashMap<(u32, u32), usize>;

/// Bisect until every edge is at most `max_edge` long.
pub fn bisect_long_edges(mesh: &mut Mesh, max_edge: f64) {
    let limit2 = max_edge * max_edge;
    let mut edges: EdgeMap = HashMap::with_capacity(mesh.triangles.len() * 3);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            edges.insert((tri[k], tri[(k + 1) % 3]), t);
        }
    }
    // New triangles are appended; the loop reaches them too.
    let mut t = 0;
    while t < mesh.triangles.len() {
        while longest_edge_length2(mesh, t) > limit2 {
            split_with_neighbour(mesh, &mut edges, t);
        }
        t += 1;
    }
}

/// The position (0..3) of the triangle's longest edge, ties broken by the
/// vertex indices so both triangles sharing an edge agree on the order.
fn longest_edge(mesh: &Mesh, t: usize) -> usize {
    let tri = mesh.triangles[t];
    let key = |k: usize| {
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let len2 = mesh.vertices[a as usize].distance_squared(mesh.vertices[b as usize]);
        (len2, a.min(b), a.max(b))
    };
    (0..3)
        .max_by(|&i, &j| {
            let (ki, kj) = (key(i), key(j));
            ki.0.total_cmp(&kj.0)
                .then(ki.1.cmp(&kj.1))
                .then(ki.2.cmp(&kj.2))
        })
        .unwrap_or(0)
}

fn longest_edge_length2(mesh: &Mesh, t: usize) -> f64 {
    let tri = mesh.triangles[t];
    let k = longest_edge(mesh, t);
    mesh.vertices[tri[k] as usize].distance_squared(mesh.vertices[tri[(k + 1) % 3] as usize])
}

/// Bisect triangle `t` at its longest edge. The neighbour across it is
/// first refined along its own longest-edge path until that edge is its
/// longest too, then both are split at the same midpoint.
fn split_with_neighbour(mesh: &mut Mesh, edges: &mut EdgeMap, t: usize) {
    // The longest-edge propagation path: each step goes to a neighbour
    // whose longest edge comes later in the total order of `longest_edge`,
    // so the path ends. Splitting the end of the path gives the triangle
    // below it a new neighbour; it is examined again until it is split.
    let mut path = vec![t];
    while let Some(&current) = path.last() {
        let tri = mesh.triangles[current];
        let k = longest_edge(mesh, current);
        let (a, b) = (tri[k], tri[(k + 1) % 3]);
        let neighbour = edges.get(&(b, a)).copied();
        let terminal = match neighbour {
            None => true,
            Some(n) => {
                let nt = mesh.triangles[n];
                let nk = longest_edge(mesh, n);
                (nt[nk], nt[(nk + 1) % 3]) == (b, a)
            }
        };
        match neighbour {
            Some(n) if !terminal => path.push(n),
            _ => {
                split_pair(mesh, edges, current, k, neighbour);
                path.pop();
            }
        }
    }
}

/// Split triangle `t` at the midpoint m of its edge `k` (a, b), and the
/// neighbour `n` across it (which has the edge as (b, a)) if any.
fn split_pair(mesh: &mut Mesh, edges: &mut EdgeMap, t: usize, k: usize, n: Option<usize>) {
    let tri = mesh.triangles[t];
    let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
    // The same point from both sides: order the end points canonically.
    let (lo, hi) = (a.min(b) as usize, a.max(b) as usize);
    let m = mesh.vertices.len() as u32;
    mesh.vertices
        .push(0.5 * (mesh.vertices[lo] + mesh.vertices[hi]));
    replace(mesh, edges, t, [a, m, c]);
    push(mesh, edges, [m, b, c]);
    let Some(n) = n else { return };
    let nt = mesh.triangles[n];
    if let Some(j) = (0..3).find(|&j| (nt[j], nt[(j + 1) % 3]) == (b, a)) {
        let d = nt[(j + 2) % 3];
        replace(mesh, edges, n, [b, m, d]);
        push(mesh, edges, [m, a, d]);
    }
}

fn unlink(edges: &mut EdgeMap, tri: [u32; 3]) {
    for k in 0..3 {
        edges.remove(&(tri[k], tri[(k + 1) % 3]));
    }
}

fn link(edges: &mut EdgeMap, tri: [u32; 3], t: usize) {
    for k in 0..3 {
        edges.insert((tri[k], tri[(k + 1) % 3]), t);
    }
}

fn replace(mesh: &mut Mesh, edges: &mut EdgeMap, t: usize, tri: [u32; 3]) {
    unlink(edges, mesh.triangles[t]);
    mesh.triangles[t] = tri;
    link(edges, tri, t);
}

fn push(mesh: &mut Mesh, edges: &mut EdgeMap, tri: [u32; 3]) {
    mesh.triangles.push(tri);
    link(edges, tri, mesh.triangles.len() - 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(mesh: &Mesh, max_edge: f64, area: f64) {
        let mut total = 0.0;
        let mut directed = std::collections::HashSet::new();
        for t in &mesh.triangles {
            let p = t.map(|i| mesh.vertices[i as usize]);
            let a = 0.5 * (p[1] - p[0]).perp_dot(p[2] - p[0]);
            assert!(a > 0.0);
            total += a;
            for k in 0..3 {
                assert!(p[k].distance(p[(k + 1) % 3]) <= max_edge);
                assert!(directed.insert((t[k], t[(k + 1) % 3])));
            }
        }
        assert!((total - area).abs() < 1e-9 * area);
        // Conforming: every vertex strictly inside an edge would be a T.
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (
                    mesh.vertices[t[k] as usize],
                    mesh.vertices[t[(k + 1) % 3] as usize],
                );
                for (i, v) in mesh.vertices.iter().enumerate() {
                    if i as u32 == t[k] || i as u32 == t[(k + 1) % 3] {
                        continue;
                    }
                    let on_line = (b - a).perp_dot(*v - a).abs() < 1e-9 * (b - a).length();
                    let inside = (*v - a).dot(b - a) > 0.0 && (*v - b).dot(a - b) > 0.0;
                    assert!(!(on_line && inside), "T-junction at {v}");
                }
            }
        }
    }

    #[test]
    fn bisection_bounds_edges_conformingly() {
        // A long thin quad made of two triangles, and a fan.
        let mut mesh = Mesh {
            vertices: vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(100.0, 0.0),
                DVec2::new(100.0, 3.0),
                DVec2::new(0.0, 3.0),
                DVec2::new(50.0, 40.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [3, 2, 4]],
        };
        let area = 300.0 + 0.5 * 100.0 * 37.0;
        bisect_long_edges(&mut mesh, 7.0);
        check(&mesh, 7.0, area);
    }
}
