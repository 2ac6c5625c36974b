//! Random scenes for the geometry and cells property tests: a rotated row
//! of wall-sharing buildings of different depths and heights, an annex
//! overlapping one of them, and free-standing star-shaped (concave)
//! buildings, some with a courtyard. Built from a seed so proptest can
//! drive them.
#![allow(dead_code)]

use citypvs::model::{Building, Polygon, Ring, distance_to_segment, polygon_edges};
use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A scene and what is known about its connectivity by construction.
pub struct Scene {
    pub buildings: Vec<Building>,
    /// Groups of building indices that must form the blocks (ascending,
    /// groups ordered by their smallest member).
    pub expected_blocks: Vec<Vec<usize>>,
}

/// A star-shaped ring around `c` with `n` vertices whose radii lie in
/// [r_min, r_max]; counter-clockwise. Angular gaps stay below 2 pi / n * 1.8.
pub fn star(rng: &mut ChaCha8Rng, c: DVec2, n: usize, r_min: f64, r_max: f64) -> Ring {
    (0..n)
        .map(|k| {
            let step = std::f64::consts::TAU / n as f64;
            let angle = step * (k as f64 + rng.random_range(-0.4..0.4));
            let r = rng.random_range(r_min..=r_max);
            c + DVec2::from_angle(angle) * r
        })
        .collect()
}

/// A star-shaped polygon, with a star-shaped courtyard when `courtyard`.
/// With at least 8 vertices the exterior keeps a disc of 0.76 r_min around
/// the centre, so a courtyard of radius at most 0.6 r_min fits inside.
pub fn star_polygon(
    rng: &mut ChaCha8Rng,
    c: DVec2,
    r_min: f64,
    r_max: f64,
    courtyard: bool,
) -> Polygon {
    let n = rng.random_range(8..16);
    let exterior = star(rng, c, n, r_min, r_max);
    let holes = if courtyard {
        let m = rng.random_range(8..12);
        let mut hole = star(rng, c, m, 0.25 * r_min, 0.6 * r_min);
        hole.reverse();
        vec![hole]
    } else {
        vec![]
    };
    Polygon { exterior, holes }
}

fn building(id: String, polygon: Polygon, height: f64) -> Building {
    Building {
        id,
        footprint: vec![polygon],
        height,
        occludes: true,
    }
}

/// A random scene. Heights come from a small set so that equal heights occur.
pub fn scene(seed: u64) -> Scene {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let heights = [4.0, 8.0, 12.0, 20.0, 35.0];
    let mut buildings = Vec::new();
    let mut expected = Vec::new();

    // The row: rectangles [x_i, x_{i+1}] x [0, depth_i], rotated and moved.
    let angle = rng.random_range(0.0..std::f64::consts::TAU);
    let origin = DVec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
    let place = |p: DVec2| origin + DVec2::from_angle(angle).rotate(p);
    let count = rng.random_range(1..6);
    let mut x = 0.0;
    let mut row = Vec::new();
    for _ in 0..count {
        let width = rng.random_range(3.0..15.0);
        let depth = rng.random_range(4.0..20.0);
        let corners = [
            DVec2::new(x, 0.0),
            DVec2::new(x + width, 0.0),
            DVec2::new(x + width, depth),
            DVec2::new(x, depth),
        ];
        row.push(buildings.len());
        buildings.push(building(
            format!("row{}", buildings.len()),
            Polygon {
                exterior: corners.iter().map(|&p| place(p)).collect(),
                holes: vec![],
            },
            heights[rng.random_range(0..heights.len())],
        ));
        x += width;
    }
    let row_length = x;
    // An annex overlapping the first row building from the street side.
    if rng.random_bool(0.5) {
        let c = DVec2::new(rng.random_range(0.5..2.5), -1.0);
        let corners = [
            c,
            c + DVec2::new(2.0, 0.0),
            c + DVec2::new(2.0, 3.0),
            c + DVec2::new(0.0, 3.0),
        ];
        row.push(buildings.len());
        buildings.push(building(
            format!("annex{}", buildings.len()),
            Polygon {
                exterior: corners.iter().map(|&p| place(p)).collect(),
                holes: vec![],
            },
            heights[rng.random_range(0..heights.len())],
        ));
    }
    expected.push(row);

    // Free-standing stars in front of the row (y < -40 in row coordinates),
    // each in its own 50 m slot so they never touch anything.
    let stars = rng.random_range(0..4);
    for k in 0..stars {
        let r_min = rng.random_range(3.0..10.0);
        let r_max = r_min + rng.random_range(0.0..10.0);
        let c = place(DVec2::new(25.0 + 50.0 * k as f64, -45.0));
        let courtyard = rng.random_bool(0.5);
        let polygon = star_polygon(&mut rng, c, r_min, r_max, courtyard);
        expected.push(vec![buildings.len()]);
        buildings.push(building(
            format!("star{}", buildings.len()),
            polygon,
            heights[rng.random_range(0..heights.len())],
        ));
    }
    let _ = row_length;
    Scene {
        buildings,
        expected_blocks: expected,
    }
}

/// Distance from `p` to the nearest boundary edge of any polygon.
pub fn boundary_distance(p: DVec2, polygons: &[Polygon]) -> f64 {
    polygons
        .iter()
        .flat_map(polygon_edges)
        .map(|(a, b)| distance_to_segment(p, a, b))
        .fold(f64::INFINITY, f64::min)
}

/// Points along every edge of the polygons (end points included).
pub fn edge_points(polygons: &[Polygon], per_edge: usize) -> Vec<DVec2> {
    polygons
        .iter()
        .flat_map(polygon_edges)
        .flat_map(|(a, b)| (0..=per_edge).map(move |k| a + (b - a) * (k as f64 / per_edge as f64)))
        .collect()
}

/// Random points in the bounding box of the polygons.
pub fn box_points(rng: &mut ChaCha8Rng, polygons: &[Polygon], n: usize) -> Vec<DVec2> {
    let pts: Vec<DVec2> = polygons
        .iter()
        .flat_map(|p| p.exterior.iter().copied())
        .collect();
    let min = pts
        .iter()
        .fold(DVec2::splat(f64::INFINITY), |m, p| m.min(*p));
    let max = pts
        .iter()
        .fold(DVec2::splat(f64::NEG_INFINITY), |m, p| m.max(*p));
    (0..n)
        .map(|_| {
            DVec2::new(
                rng.random_range(min.x..=max.x),
                rng.random_range(min.y..=max.y),
            )
        })
        .collect()
}

/// Model conventions: CCW exteriors, CW holes, open rings of at least three
/// vertices, no repeated consecutive vertices, positive area.
pub fn assert_model_polygons(polygons: &[Polygon]) {
    use citypvs::model::ring_signed_area2;
    for p in polygons {
        assert!(ring_signed_area2(&p.exterior) > 0.0, "exterior not CCW");
        for h in &p.holes {
            assert!(ring_signed_area2(h) < 0.0, "hole not CW");
        }
        for ring in std::iter::once(&p.exterior).chain(p.holes.iter()) {
            assert!(ring.len() >= 3);
            let mut sorted: Vec<(f64, f64)> = ring.iter().map(|p| (p.x, p.y)).collect();
            sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
            for pair in sorted.windows(2) {
                assert_ne!(pair[0], pair[1], "a ring visits a vertex twice");
            }
        }
    }
}
