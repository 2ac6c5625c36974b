//! Which cells the judge checks and where its viewpoints lie in each cell
//! prism. Everything is drawn from ChaCha8 streams keyed by the seed (and the
//! cell index), so the choice does not depend on threads or on other cells.

use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The lowest viewpoint height in metres (or the eye height, if lower).
pub const LOWEST_VIEWPOINT: f64 = 0.05;
/// Viewpoints are moved this far (metres) towards the cell's centroid, off
/// the footprint outlines the cell edges lie on.
pub const NUDGE: f64 = 1e-6;

/// The cells to check, ascending: all of them, or `k` drawn without
/// replacement.
pub fn choose_cells(count: usize, k: Option<usize>, seed: u64) -> Vec<usize> {
    match k {
        Some(k) if k < count => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut chosen = rand::seq::index::sample(&mut rng, count, k).into_vec();
            chosen.sort_unstable();
            chosen
        }
        _ => (0..count).collect(),
    }
}

/// `samples` viewpoints in the prism of `triangle` from the ground to
/// `eye_height`: its three top corners first, then about half of the rest
/// spread along the top edges (stratified by perimeter length), a quarter
/// inside the top triangle, and the rest at random heights from
/// [`LOWEST_VIEWPOINT`] up, alternately on the side faces and inside.
pub fn cell_viewpoints(
    triangle: &[DVec2; 3],
    eye_height: f64,
    samples: usize,
    seed: u64,
    cell: usize,
) -> Vec<DVec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(cell as u64 + 1);
    let corners = samples.min(3);
    let rest = samples - corners;
    let on_edges = rest.div_ceil(2);
    let inside = rest / 4;
    let low = rest - on_edges - inside;
    let lowest = LOWEST_VIEWPOINT.min(eye_height);

    let mut points: Vec<DVec3> = Vec::with_capacity(samples);
    points.extend(triangle[..corners].iter().map(|c| c.extend(eye_height)));
    for i in 0..on_edges {
        let u = (i as f64 + rng.random::<f64>()) / on_edges as f64;
        points.push(on_perimeter(triangle, u).extend(eye_height));
    }
    for _ in 0..inside {
        points.push(in_triangle(triangle, &mut rng).extend(eye_height));
    }
    for i in 0..low {
        let p = if i % 2 == 0 {
            on_perimeter(triangle, rng.random::<f64>())
        } else {
            in_triangle(triangle, &mut rng)
        };
        let z = lowest + (eye_height - lowest) * rng.random::<f64>();
        points.push(p.extend(z));
    }
    let centroid = (triangle[0] + triangle[1] + triangle[2]) / 3.0;
    for p in &mut points {
        let to_centre = centroid - p.truncate();
        let d = to_centre.length();
        if d > 0.0 {
            let step = to_centre * (NUDGE.min(d) / d);
            p.x += step.x;
            p.y += step.y;
        }
    }
    points
}

/// The point at fraction `u` in [0, 1) of the perimeter, from corner 0.
fn on_perimeter(t: &[DVec2; 3], u: f64) -> DVec2 {
    let lengths = [
        t[0].distance(t[1]),
        t[1].distance(t[2]),
        t[2].distance(t[0]),
    ];
    let total: f64 = lengths.iter().sum();
    if total <= 0.0 {
        return t[0];
    }
    let mut along = u * total;
    for (k, len) in lengths.iter().enumerate() {
        if along <= *len || k == 2 {
            let f = if *len > 0.0 {
                (along / len).clamp(0.0, 1.0)
            } else {
                0.0
            };
            return t[k].lerp(t[(k + 1) % 3], f);
        }
        along -= len;
    }
    t[0]
}

/// A uniformly random point of the triangle.
fn in_triangle(t: &[DVec2; 3], rng: &mut ChaCha8Rng) -> DVec2 {
    let (mut a, mut b): (f64, f64) = (rng.random(), rng.random());
    if a + b > 1.0 {
        a = 1.0 - a;
        b = 1.0 - b;
    }
    t[0] + (t[1] - t[0]) * a + (t[2] - t[0]) * b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viewpoints_lie_in_the_prism_and_repeat_for_a_seed() {
        let t = [
            DVec2::new(0.0, 0.0),
            DVec2::new(10.0, 0.0),
            DVec2::new(0.0, 6.0),
        ];
        let a = cell_viewpoints(&t, 1.7, 64, 9, 4);
        assert_eq!(a, cell_viewpoints(&t, 1.7, 64, 9, 4));
        assert_ne!(a, cell_viewpoints(&t, 1.7, 64, 9, 5));
        assert_eq!(a.len(), 64);
        let at_eye = a.iter().filter(|p| p.z == 1.7).count();
        assert!((40..64).contains(&at_eye), "{at_eye}");
        assert!(a.iter().any(|p| p.z < 0.5));
        for p in &a {
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x / 10.0 + p.y / 6.0 <= 1.0 + 1e-12);
            assert!(p.z >= LOWEST_VIEWPOINT && p.z <= 1.7);
        }
        // The corners come first, nudged by NUDGE towards the centroid.
        assert!(a[1].truncate().distance(t[1]) <= NUDGE * 1.000001);
        assert!(a[1].truncate().distance(t[1]) > 0.0);
    }

    #[test]
    fn cell_choice_is_sorted_distinct_and_seeded() {
        let c = choose_cells(1000, Some(50), 3);
        assert_eq!(c.len(), 50);
        assert!(c.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(c, choose_cells(1000, Some(50), 3));
        assert_ne!(c, choose_cells(1000, Some(50), 4));
        assert_eq!(choose_cells(7, Some(50), 3), (0..7).collect::<Vec<_>>());
        assert_eq!(choose_cells(7, None, 3).len(), 7);
    }
}
