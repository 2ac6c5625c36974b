//! Tests of `citypvs generate`: determinism, the GeoJSON contract (count,
//! ids, heights, kinds, ring orientation, closure, rounding), and the city's
//! geometry read back from the written file (no overlaps, valid polygons,
//! shared walls, courtyards, the river strip, the open square, density).

use std::collections::{BTreeMap, BTreeSet};

use citypvs::generate::{
    GRID_ROTATION_DEG, GenerateParams, frame, generate_buildings, generate_city, generate_geojson,
};
use geo::{Area, BooleanOps, BoundingRect, ConvexHull, Intersects, Validation};
use glam::DVec2;

fn params(buildings: usize, seed: u64) -> GenerateParams {
    GenerateParams { buildings, seed }
}

/// One feature of the written file.
struct Feature {
    id: String,
    kind: String,
    height: f64,
    /// Rings as written: lon/lat, closed.
    rings: Vec<Vec<[f64; 2]>>,
}

fn parse(text: &str) -> Vec<Feature> {
    let doc: serde_json::Value = serde_json::from_str(text).expect("valid JSON");
    assert_eq!(doc["type"], "FeatureCollection");
    doc["features"]
        .as_array()
        .expect("features array")
        .iter()
        .map(|f| {
            assert_eq!(f["type"], "Feature");
            assert_eq!(f["geometry"]["type"], "Polygon");
            let rings = f["geometry"]["coordinates"]
                .as_array()
                .unwrap()
                .iter()
                .map(|r| {
                    r.as_array()
                        .unwrap()
                        .iter()
                        .map(|p| [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()])
                        .collect()
                })
                .collect();
            Feature {
                id: f["id"].as_str().expect("string id").to_string(),
                kind: f["properties"]["kind"].as_str().unwrap().to_string(),
                height: f["properties"]["height"].as_f64().expect("numeric height"),
                rings,
            }
        })
        .collect()
}

/// Twice the signed area of a closed ring in lon/lat (positive = CCW).
fn signed_area2(ring: &[[f64; 2]]) -> f64 {
    ring.windows(2)
        .map(|w| w[0][0] * w[1][1] - w[1][0] * w[0][1])
        .sum()
}

/// The written footprints back in local metres, as geo polygons.
fn local_polygons(features: &[Feature]) -> Vec<geo::Polygon<f64>> {
    let frame = frame();
    features
        .iter()
        .map(|f| {
            let mut rings = f.rings.iter().map(|r| {
                geo::LineString::from(
                    r.iter()
                        .map(|p| {
                            let q = frame.to_local(p[0], p[1]);
                            (q.x, q.y)
                        })
                        .collect::<Vec<_>>(),
                )
            });
            let exterior = rings.next().unwrap();
            geo::Polygon::new(exterior, rings.collect())
        })
        .collect()
}

/// A local point turned into the street grid's frame (undo the rotation).
fn to_grid(x: f64, y: f64) -> DVec2 {
    let (s, c) = (-GRID_ROTATION_DEG).to_radians().sin_cos();
    DVec2::new(x * c - y * s, x * s + y * c)
}

/// Each building's bounding box in the grid frame (footprints are rectangles there).
fn grid_boxes(polygons: &[geo::Polygon<f64>]) -> Vec<(DVec2, DVec2)> {
    polygons
        .iter()
        .map(|p| {
            let pts: Vec<DVec2> = p
                .exterior()
                .points()
                .map(|q| to_grid(q.x(), q.y()))
                .collect();
            let lo = pts.iter().fold(DVec2::splat(f64::MAX), |a, b| a.min(*b));
            let hi = pts.iter().fold(DVec2::splat(f64::MIN), |a, b| a.max(*b));
            (lo, hi)
        })
        .collect()
}

#[test]
fn same_seed_gives_identical_bytes_and_different_seeds_differ() {
    let a = generate_geojson(&params(400, 7));
    let b = generate_geojson(&params(400, 7));
    let c = generate_geojson(&params(400, 8));
    assert_eq!(a, b);
    assert_ne!(a, c);
}

#[test]
fn exactly_n_features_with_unique_string_ids() {
    for n in [0, 1, 7, 300, 2500] {
        let features = parse(&generate_geojson(&params(n, 3)));
        assert_eq!(features.len(), n, "n = {n}");
        let ids: BTreeSet<&str> = features.iter().map(|f| f.id.as_str()).collect();
        assert_eq!(ids.len(), n, "ids not unique for n = {n}");
        for (i, f) in features.iter().enumerate() {
            assert_eq!(f.id, format!("b{i}"));
        }
    }
}

#[test]
fn heights_and_kinds_are_in_range() {
    let features = parse(&generate_geojson(&params(3000, 11)));
    let mut kinds = BTreeMap::new();
    for f in &features {
        *kinds.entry(f.kind.as_str()).or_insert(0usize) += 1;
        let (lo, hi) = if f.kind == "tower" {
            (40.0, 120.0)
        } else {
            (6.0, 30.0)
        };
        assert!(
            (lo..=hi).contains(&f.height),
            "{} ({}) has height {}",
            f.id,
            f.kind,
            f.height
        );
    }
    assert_eq!(
        kinds.keys().copied().collect::<Vec<_>>(),
        ["courtyard", "house", "row", "tower"]
    );
    // Towers are few; rows dominate.
    assert!(kinds["tower"] * 50 < features.len(), "{kinds:?}");
    assert!(kinds["row"] * 2 > features.len(), "{kinds:?}");
}

#[test]
fn rings_follow_rfc7946() {
    let text = generate_geojson(&params(300, 5));
    for f in parse(&text) {
        for (i, ring) in f.rings.iter().enumerate() {
            assert!(ring.len() >= 4, "{}: ring too short", f.id);
            assert_eq!(ring.first(), ring.last(), "{}: ring not closed", f.id);
            let area = signed_area2(ring);
            if i == 0 {
                assert!(area > 0.0, "{}: exterior not counter-clockwise", f.id);
            } else {
                assert!(area < 0.0, "{}: hole not clockwise", f.id);
            }
            for p in ring {
                for c in p {
                    let scaled = c * 1e7;
                    assert!((scaled - scaled.round()).abs() < 1e-3, "{c} not rounded");
                }
            }
        }
    }
}

#[test]
fn footprints_are_valid_and_never_overlap() {
    let features = parse(&generate_geojson(&params(300, 2)));
    let polygons = local_polygons(&features);
    let boxes: Vec<_> = polygons
        .iter()
        .map(|p| p.bounding_rect().unwrap())
        .collect();
    let mut touching = 0;
    for (i, p) in polygons.iter().enumerate() {
        assert!(p.is_valid(), "{} is not a valid polygon", features[i].id);
        assert!(p.unsigned_area() > 50.0, "{} is tiny", features[i].id);
        for j in i + 1..polygons.len() {
            if !boxes[i].intersects(&boxes[j]) {
                continue;
            }
            let overlap = p.intersection(&polygons[j]).unsigned_area();
            assert!(
                overlap < 1e-3,
                "{} and {} overlap by {overlap} m^2",
                features[i].id,
                features[j].id
            );
            touching += usize::from(p.intersects(&polygons[j]));
        }
    }
    assert!(touching > 100, "only {touching} touching pairs");
}

#[test]
fn neighbours_share_walls_with_identical_vertices() {
    let features = parse(&generate_geojson(&params(300, 4)));
    // Every directed edge as written, with its owner.
    let key = |p: &[f64; 2]| (p[0].to_bits(), p[1].to_bits());
    let mut edges = BTreeMap::new();
    for (i, f) in features.iter().enumerate() {
        for ring in &f.rings {
            for w in ring.windows(2) {
                edges.insert((key(&w[0]), key(&w[1])), i);
            }
        }
    }
    // A shared wall is an edge another building has in the opposite direction.
    let shared = edges
        .iter()
        .filter(|((a, b), i)| edges.get(&(*b, *a)).is_some_and(|j| j != *i))
        .count();
    assert!(shared >= 100, "only {shared} shared wall edges");
    // Row buildings mostly share walls; houses and towers stand free.
    let mut sharing = BTreeSet::new();
    for ((a, b), i) in &edges {
        if edges.get(&(*b, *a)).is_some_and(|j| j != i) {
            sharing.insert(*i);
        }
    }
    for i in &sharing {
        assert!(
            ["row", "courtyard"].contains(&features[*i].kind.as_str()),
            "{} ({}) shares a wall",
            features[*i].id,
            features[*i].kind
        );
    }
}

#[test]
fn some_buildings_have_courtyard_holes() {
    let features = parse(&generate_geojson(&params(1000, 1)));
    let with_holes: Vec<_> = features.iter().filter(|f| f.rings.len() > 1).collect();
    assert!(!with_holes.is_empty());
    assert!(with_holes.iter().all(|f| f.kind == "courtyard"));
}

/// The widest gap between buildings across the city in the grid's v
/// direction: (start, end) of the gap, with buildings on both sides.
fn widest_v_gap(boxes: &[(DVec2, DVec2)]) -> (f64, f64) {
    let mut spans: Vec<(f64, f64)> = boxes.iter().map(|(lo, hi)| (lo.y, hi.y)).collect();
    spans.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = (0.0, 0.0);
    let mut reach = spans[0].1;
    for s in &spans[1..] {
        if s.0 - reach > best.1 - best.0 {
            best = (reach, s.0);
        }
        reach = reach.max(s.1);
    }
    best
}

#[test]
fn a_river_strip_crosses_the_city() {
    for (n, seed) in [(300, 1), (1000, 2), (5000, 3)] {
        let features = parse(&generate_geojson(&params(n, seed)));
        let boxes = grid_boxes(&local_polygons(&features));
        let (v0, v1) = widest_v_gap(&boxes);
        let width = v1 - v0;
        assert!(
            (40.0..=80.0).contains(&width),
            "n = {n}: widest gap {width} m"
        );
        // It runs across the city: buildings on both sides, and at least a
        // fifth of them on the smaller side.
        let below = boxes.iter().filter(|(_, hi)| hi.y <= v0).count();
        assert!(
            below.min(n - below) * 5 >= n,
            "n = {n}: {below} below the river"
        );
    }
}

fn geo_polygon(p: &citypvs::model::Polygon) -> geo::Polygon<f64> {
    let ring =
        |r: &Vec<DVec2>| geo::LineString::from(r.iter().map(|q| (q.x, q.y)).collect::<Vec<_>>());
    geo::Polygon::new(ring(&p.exterior), p.holes.iter().map(ring).collect())
}

#[test]
fn the_open_square_and_the_river_stay_empty_among_buildings() {
    for (n, seed) in [(300, 1), (1000, 6), (3000, 7)] {
        let city = generate_city(&params(n, seed));
        let buildings: Vec<_> = city
            .buildings
            .iter()
            .map(|b| geo_polygon(&b.footprint))
            .collect();
        let square = geo_polygon(&city.square);
        let river = geo_polygon(&city.river);
        // The square is a real square (two blocks and the street between) ...
        assert!(
            square.unsigned_area() >= 130.0 * 60.0,
            "n = {n}: square too small"
        );
        // ... and the river runs across the whole city.
        let river_box = grid_boxes(std::slice::from_ref(&river))[0];
        let boxes = grid_boxes(&buildings);
        let width = river_box.1.y - river_box.0.y;
        assert!(
            (40.0..=70.0).contains(&width),
            "n = {n}: river {width} m wide"
        );
        assert!(
            boxes
                .iter()
                .all(|b| river_box.0.x <= b.0.x && b.1.x <= river_box.1.x)
        );
        for open in [&square, &river] {
            for (b, f) in buildings.iter().zip(&city.buildings) {
                let overlap = b.intersection(open).unsigned_area();
                assert!(
                    overlap < 1e-6,
                    "n = {n}: {} stands in the open by {overlap} m^2",
                    f.id
                );
            }
        }
        // The square lies among buildings: some within 60 m beyond each side.
        let square_box = grid_boxes(std::slice::from_ref(&square))[0];
        let (lo, hi) = square_box;
        let mid = 0.5 * (lo + hi);
        let beyond = |b: &(DVec2, DVec2), side: usize| match side {
            0 => b.0.x >= hi.x && b.0.x < hi.x + 60.0 && b.1.y > lo.y && b.0.y < hi.y,
            1 => b.1.x <= lo.x && b.1.x > lo.x - 60.0 && b.1.y > lo.y && b.0.y < hi.y,
            2 => b.0.y >= hi.y && b.0.y < hi.y + 60.0 && b.1.x > lo.x && b.0.x < hi.x,
            _ => b.1.y <= lo.y && b.1.y > lo.y - 60.0 && b.1.x > lo.x && b.0.x < hi.x,
        };
        for side in 0..4 {
            assert!(
                boxes.iter().any(|b| beyond(b, side)),
                "n = {n}: no buildings on side {side} of the square around {mid}"
            );
        }
    }
}

#[test]
fn density_is_about_a_thousand_buildings_per_square_kilometre() {
    for n in [1000, 4000] {
        let buildings = generate_buildings(&params(n, 9));
        let points: Vec<geo::Point<f64>> = buildings
            .iter()
            .flat_map(|b| {
                b.footprint
                    .exterior
                    .iter()
                    .map(|p| geo::Point::new(p.x, p.y))
            })
            .collect();
        let hull_km2 = geo::MultiPoint::from(points).convex_hull().unsigned_area() / 1e6;
        let density = n as f64 / hull_km2;
        assert!(
            (700.0..=1400.0).contains(&density),
            "n = {n}: {density:.0} buildings per km^2 over {hull_km2:.2} km^2"
        );
        // Centred on the origin.
        let mean = buildings
            .iter()
            .map(|b| b.footprint.exterior[0])
            .sum::<DVec2>()
            / n as f64;
        assert!(mean.length() < 0.2 * (hull_km2 * 1e6).sqrt(), "mean {mean}");
    }
}
