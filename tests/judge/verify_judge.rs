//! The judge (`citypvs::verify`): known visible sets of hand-made scenes from
//! single viewpoints and from cells, a brute-force cross-check on random
//! scenes, and whole-PVS verdicts (a broken PVS is caught, a superset passes).

use crate::common::{block, generated_buildings, ring_building};
use citypvs::generate::Style;
use citypvs::model::{Building, Polygon, point_in_multipolygon, polygon_edges};
use citypvs::verify::{Judge, Scratch, VerifyOptions, View, verify};
use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Ids of the buildings seen from `p`, sorted.
fn seen_ids(buildings: &[Building], p: DVec3) -> Vec<String> {
    let judge = Judge::new(buildings);
    match judge.view(p, &mut Scratch::default()) {
        View::Seen { sightings, .. } => {
            let mut ids: Vec<String> = sightings
                .iter()
                .map(|s| buildings[s.building as usize].id.clone())
                .collect();
            ids.sort();
            ids
        }
        View::InsideBuilding { building, .. } => {
            panic!("viewpoint inside {}", buildings[building as usize].id)
        }
    }
}

fn ids(list: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = list.iter().map(|s| s.to_string()).collect();
    v.sort();
    v
}

// ---------------------------------------------------------------------------
// An independent brute-force reference: straight-line clearance tests.

/// True when the segment from `p` to `q` passes through no occluding
/// building's interior (touching walls and roofs is allowed).
fn segment_clear(buildings: &[Building], p: DVec3, q: DVec3) -> bool {
    let (p2, q2) = (p.truncate(), q.truncate());
    let d = q2 - p2;
    buildings.iter().filter(|b| b.occludes).all(|b| {
        let mut cuts = vec![0.0, 1.0];
        for poly in &b.footprint {
            for (a, c) in polygon_edges(poly) {
                let e = c - a;
                let den = d.perp_dot(e);
                if den.abs() < 1e-15 {
                    continue;
                }
                let lambda = (a - p2).perp_dot(e) / den;
                let mu = (a - p2).perp_dot(d) / den;
                if (0.0..=1.0).contains(&lambda) && (-1e-12..=1.0 + 1e-12).contains(&mu) {
                    cuts.push(lambda);
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.windows(2).all(|w| {
            if w[1] - w[0] < 1e-9 {
                return true;
            }
            let mid = p2 + d * (0.5 * (w[0] + w[1]));
            if !point_in_multipolygon(mid, &b.footprint) {
                return true;
            }
            let z = |l: f64| p.z + (q.z - p.z) * l;
            z(w[0]).min(z(w[1])) >= b.height - 1e-6
        })
    })
}

/// Points every `step` metres along every footprint outline.
fn outline_points(b: &Building, step: f64) -> Vec<DVec2> {
    b.footprint
        .iter()
        .flat_map(polygon_edges)
        .flat_map(|(a, c)| {
            let n = ((a.distance(c) / step).ceil() as usize).max(1);
            (0..=n).map(move |i| a.lerp(c, i as f64 / n as f64))
        })
        .collect()
}

/// Buildings with some point of their roof's outline seen from `p` by an
/// unobstructed straight segment. Besides its own outline, a roof's outline
/// includes the feet of other buildings' walls standing on it (overlapping
/// footprints). Points every `step` metres.
fn brute_force_seen(buildings: &[Building], p: DVec3, step: f64) -> Vec<String> {
    let outlines: Vec<Vec<DVec2>> = buildings.iter().map(|b| outline_points(b, step)).collect();
    let mut out: Vec<String> = buildings
        .iter()
        .enumerate()
        .filter(|&(i, b)| {
            let on_roof = outlines.iter().enumerate().flat_map(|(j, pts)| {
                pts.iter()
                    .filter(move |q| j == i || point_in_multipolygon(**q, &b.footprint))
            });
            on_roof
                .into_iter()
                .any(|q| segment_clear(buildings, p, q.extend(b.height)))
        })
        .map(|(_, b)| b.id.clone())
        .collect();
    out.sort();
    out
}

fn distance_to_outline(b: &Building, q: DVec2) -> f64 {
    b.footprint
        .iter()
        .flat_map(polygon_edges)
        .map(|(a, c)| citypvs::model::distance_to_segment(q, a, c))
        .fold(f64::INFINITY, f64::min)
}

// ---------------------------------------------------------------------------
// Single viewpoints with known answers.

#[test]
fn a_wall_hides_a_low_house() {
    let city = vec![
        block("wall", 10.0, -20.0, 11.0, 20.0, 10.0),
        block("house", 20.0, -5.0, 30.0, 5.0, 5.0),
        block("behind_me", -30.0, -5.0, -20.0, 5.0, 5.0),
    ];
    let eye = DVec3::new(0.0, 0.0, 1.7);
    assert_eq!(seen_ids(&city, eye), ids(&["wall", "behind_me"]));
    // From high above the wall's top the house's roof shows.
    assert_eq!(
        seen_ids(&city, DVec3::new(0.0, 0.0, 40.0)),
        ids(&["wall", "house", "behind_me"])
    );
    // Just off the wall's end, the house is in plain view.
    assert_eq!(
        seen_ids(&city, DVec3::new(12.0, 30.0, 1.7)),
        ids(&["wall", "house", "behind_me"])
    );
}

#[test]
fn a_tall_house_shows_over_a_low_one() {
    let city = vec![
        block("low", 10.0, -20.0, 15.0, 20.0, 4.0),
        block("tower", 25.0, -5.0, 35.0, 5.0, 30.0),
        block("hidden", 20.0, 10.0, 23.0, 13.0, 4.0),
    ];
    let judge = Judge::new(&city);
    let View::Seen { sightings, .. } =
        judge.view(DVec3::new(0.0, 0.0, 1.7), &mut Scratch::default())
    else {
        panic!("inside a building");
    };
    let names: Vec<&str> = sightings
        .iter()
        .map(|s| city[s.building as usize].id.as_str())
        .collect();
    assert_eq!(names, ["low", "tower"]);
    // The tower is seen at the top of its near wall (x = 25, z = 30).
    let w = sightings[1].witness;
    assert!(
        (w.x - 25.0).abs() < 1e-9 && (w.z - 30.0).abs() < 1e-12,
        "{w}"
    );
    assert!(w.y.abs() <= 5.0 + 1e-9);
    assert!(segment_clear(&city, DVec3::new(0.0, 0.0, 1.7), w));
    // A tower just too low to clear the wall (elevation 2.3/10 at x = 10
    // needs a height of 1.7 + 0.23 * 25 = 7.45 at x = 25) stays hidden.
    let lower = vec![city[0].clone(), block("tower", 25.0, -5.0, 35.0, 5.0, 7.4)];
    assert_eq!(seen_ids(&lower, DVec3::new(0.0, 0.0, 1.7)), ids(&["low"]));
    let higher = vec![city[0].clone(), block("tower", 25.0, -5.0, 35.0, 5.0, 7.5)];
    assert_eq!(
        seen_ids(&higher, DVec3::new(0.0, 0.0, 1.7)),
        ids(&["low", "tower"])
    );
}

#[test]
fn a_narrow_gap_between_walls_is_seen_through() {
    // Two walls with a 0.1 m gap at x = 10..11 around y = 0.
    let walls = || {
        vec![
            block("south", 10.0, -30.0, 11.0, -0.05, 20.0),
            block("north", 10.0, 0.05, 11.0, 30.0, 20.0),
        ]
    };
    let mut city = walls();
    city.push(block("far", 200.0, -1.0, 210.0, 1.0, 3.0));
    city.push(block("beside", 200.0, 5.0, 210.0, 8.0, 3.0));
    let eye = DVec3::new(0.0, 0.0, 1.7);
    // Through the gap the sight lines reach y within +-0.05 * 200/11 ~ 1 m at
    // x = 200: "far" shows, "beside" does not.
    assert_eq!(seen_ids(&city, eye), ids(&["south", "north", "far"]));
    // Closing the gap hides both.
    let mut closed = vec![
        block("south", 10.0, -30.0, 11.0, 0.0, 20.0),
        block("north", 10.0, 0.0, 11.0, 30.0, 20.0),
    ];
    closed.extend(city[2..].iter().cloned());
    assert_eq!(seen_ids(&closed, eye), ids(&["south", "north"]));
    // A thin target 500 m away, seen only through a 0.1 m gap 10 m away
    // (a cone about 5 m wide there): found, not sampled past.
    let mut far = walls();
    far.push(block("needle", 500.0, 1.5, 500.2, 1.6, 2.0));
    assert_eq!(
        seen_ids(&far, DVec3::new(0.0, 0.0, 1.7)),
        ids(&["south", "north", "needle"])
    );
}

#[test]
fn a_courtyard_is_closed_to_the_street() {
    let city = vec![
        ring_building("ring", DVec2::ZERO, 30.0, 15.0, 12.0),
        block("shed", -5.0, -5.0, 5.0, 5.0, 3.0),
        block("street", 50.0, -10.0, 60.0, 10.0, 8.0),
    ];
    // From the street the shed inside the courtyard is hidden.
    assert_eq!(
        seen_ids(&city, DVec3::new(40.0, 0.0, 1.7)),
        ids(&["ring", "street"])
    );
    // From inside the courtyard: the ring and the shed, not the street.
    assert_eq!(
        seen_ids(&city, DVec3::new(10.0, 10.0, 1.7)),
        ids(&["ring", "shed"])
    );
    // From 13 m up, in the courtyard, the street house's roof (8 m, 50 m
    // away) is hidden by the 12 m ring (20 m away); from 100 m up it shows.
    assert_eq!(
        seen_ids(&city, DVec3::new(10.0, 10.0, 13.0)),
        ids(&["ring", "shed"])
    );
    assert_eq!(
        seen_ids(&city, DVec3::new(10.0, 10.0, 100.0)),
        ids(&["ring", "shed", "street"])
    );
}

#[test]
fn houses_sharing_a_wall_and_lifted_parts() {
    // A row of three touching houses along x; from the street in front
    // (y < 0) all fronts show; a house behind the row does not, unless it is
    // a tower.
    let mut city = vec![
        block("r1", 0.0, 0.0, 10.0, 10.0, 9.0),
        block("r2", 10.0, 0.0, 20.0, 10.0, 12.0),
        block("r3", 20.0, 0.0, 30.0, 10.0, 9.0),
        block("back", 10.0, 15.0, 20.0, 25.0, 9.0),
        block("tower", 0.0, 30.0, 10.0, 40.0, 60.0),
    ];
    let eye = DVec3::new(15.0, -8.0, 1.7);
    assert_eq!(seen_ids(&city, eye), ids(&["r1", "r2", "r3", "tower"]));
    // A lifted part (a bridge, not an occluder) over the street is seen and
    // hides nothing.
    let mut bridge = block("bridge", -5.0, -20.0, 35.0, -15.0, 7.0);
    bridge.occludes = false;
    city.push(bridge);
    city.push(block("across", 10.0, -40.0, 20.0, -30.0, 5.0));
    assert_eq!(
        seen_ids(&city, eye),
        ids(&["r1", "r2", "r3", "tower", "bridge", "across"])
    );
    // Standing under it, it is overhead: seen.
    assert_eq!(
        seen_ids(&city, DVec3::new(15.0, -17.0, 1.7)),
        ids(&["r1", "r2", "r3", "tower", "bridge", "across"])
    );
    // Inside an occluding building the judge refuses, and says how deep.
    let judge = Judge::new(&city);
    let View::InsideBuilding { building, depth } =
        judge.view(DVec3::new(5.0, 5.0, 1.7), &mut Scratch::default())
    else {
        panic!("a viewpoint inside r1 is judged");
    };
    assert_eq!((building, depth), (0, 5.0));
}

#[test]
fn viewpoints_a_rounding_error_inside_a_wall_are_moved_out() {
    let city = vec![
        block("wall", 0.0, 0.0, 10.0, 10.0, 10.0),
        block("opposite", 0.0, -20.0, 10.0, -10.0, 10.0),
    ];
    let judge = Judge::new(&city);
    let mut scratch = Scratch::default();
    // 0.5 mm inside the wall's south face: judged from just outside it.
    match judge.view(DVec3::new(5.0, 0.0005, 1.7), &mut scratch) {
        View::Seen {
            from, sightings, ..
        } => {
            assert!(from.y < 0.0 && from.y > -1e-5 && from.x == 5.0, "{from}");
            let seen: Vec<u32> = sightings.iter().map(|s| s.building).collect();
            assert_eq!(seen, [0, 1]);
        }
        other => panic!("{other:?}"),
    }
    // 2.5 mm inside (a cell corner put on the file's grid of 1/256 m may
    // reach up to 2.8 mm into a building): judged from just outside it.
    match judge.view(DVec3::new(5.0, 0.0025, 1.7), &mut scratch) {
        View::Seen { from, .. } => {
            assert!(from.y < 0.0 && from.y > -1e-5 && from.x == 5.0, "{from}")
        }
        other => panic!("{other:?}"),
    }
    // 5 mm inside: refused.
    match judge.view(DVec3::new(5.0, 0.005, 1.7), &mut scratch) {
        View::InsideBuilding { building, depth } => {
            assert_eq!(building, 0);
            assert!((depth - 0.005).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn viewpoints_in_the_seam_of_touching_buildings_are_moved_to_free_space() {
    // Two buildings sharing a wall, the street south of them. A viewpoint
    // 0.1 mm inside the west one and 0.4 mm north of the street: stepping
    // out of the west building steps into the east one and back; the
    // judge takes a free point within 2.8 mm instead.
    let city = vec![
        block("west", 0.0, 0.0, 10.0, 10.0, 10.0),
        block("east", 10.0, 0.0, 20.0, 10.0, 10.0),
        block("opposite", 0.0, -20.0, 20.0, -10.0, 10.0),
    ];
    let judge = Judge::new(&city);
    let p = DVec3::new(9.9999, 0.0004, 1.7);
    match judge.view(p, &mut Scratch::default()) {
        View::Seen {
            from, sightings, ..
        } => {
            assert!(from.y <= 0.0, "{from} is not in the street");
            assert!(from.truncate().distance(p.truncate()) <= 2.8e-3, "{from}");
            let seen: Vec<u32> = sightings.iter().map(|s| s.building).collect();
            assert_eq!(seen, [0, 1, 2]);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn overlapping_footprints_are_judged_as_solids() {
    // An outline with a tower part and a low part inside it (OpenStreetMap
    // style), seen from outside.
    let city = vec![
        block("outline", 10.0, -10.0, 50.0, 10.0, 5.0),
        block("tower_part", 30.0, -5.0, 40.0, 5.0, 20.0),
        block("low_part", 15.0, -3.0, 20.0, 3.0, 3.0),
    ];
    // From 10 m up the outline's roof shows in front of the tower part (its
    // far edge, behind the tower, does not); the low part is buried.
    assert_eq!(
        seen_ids(&city, DVec3::new(0.0, 0.0, 10.0)),
        ids(&["outline", "tower_part"])
    );
    assert_eq!(
        seen_ids(&city, DVec3::new(0.0, 0.0, 1.7)),
        ids(&["outline", "tower_part"])
    );
    // A low part sticking out of the outline shows.
    let mut out = city.clone();
    out[2] = block("low_part", 5.0, -3.0, 20.0, 3.0, 3.0);
    assert_eq!(
        seen_ids(&out, DVec3::new(0.0, 0.0, 1.7)),
        ids(&["outline", "tower_part", "low_part"])
    );
}

/// Parts inside an outline whose near walls lie on the outline's wall: the
/// parts' walls are on the outline's face, so a sight line to their tops
/// only touches the outline and they are seen, whatever order the
/// crossings at that one distance come in (and whichever wedges the
/// directions are cut into).
#[test]
fn parts_whose_walls_lie_on_a_taller_wall_are_seen() {
    let city = vec![
        block("outline", -30.0, -0.25, 30.0, 0.25, 22.75),
        block("low_part", -0.25, -0.25, 0.25, 0.25, 0.25),
        block("mid_part", 2.0, -0.25, 3.0, 0.25, 5.0),
        block("hidden_part", 5.0, -0.1, 6.0, 0.25, 5.0),
    ];
    let forms = [
        Judge::new(&city),
        Judge::new(&city).with_first_cuts_within(0.0),
        Judge::new(&city).with_first_cuts_within(f64::INFINITY),
    ];
    let mut scratch = Scratch::default();
    for p in [
        DVec3::new(-1.3, -1.3, 1.7),
        DVec3::new(0.7, -4.0, 1.7),
        DVec3::new(2.5, -9.0, 0.5),
        DVec3::new(-20.0, -3.0, 1.7),
    ] {
        for judge in &forms {
            let (seen, _) = seen_and_rays(judge, p, &mut scratch).unwrap();
            let names: Vec<&str> = seen.iter().map(|&b| city[b as usize].id.as_str()).collect();
            assert_eq!(names, ["outline", "low_part", "mid_part"], "from {p}");
        }
    }
}

/// A viewpoint exactly on a wall is judged from just outside it: at ground
/// level behind a low wall, every sight line to the tower beyond runs
/// through the wall; from eye height it clears it.
#[test]
fn viewpoints_on_a_wall_are_judged_from_just_outside() {
    let city = vec![
        block("wall", -30.0, -2.0, 30.0, 0.0, 0.25),
        block("tower", -26.0, -157.0, 26.0, -93.0, 63.75),
    ];
    let forms = [
        Judge::new(&city),
        Judge::new(&city).with_first_cuts_within(0.0),
        Judge::new(&city).with_first_cuts_within(f64::INFINITY),
    ];
    let mut scratch = Scratch::default();
    for (p, want) in [
        (DVec3::new(10.4, 0.0, 0.0), &["wall"][..]),
        (DVec3::new(30.0, 0.0, 0.0), &["wall"][..]),
        (DVec3::new(10.4, 0.0, 1.7), &["wall", "tower"][..]),
    ] {
        for judge in &forms {
            let (seen, _) = seen_and_rays(judge, p, &mut scratch).unwrap();
            let names: Vec<&str> = seen.iter().map(|&b| city[b as usize].id.as_str()).collect();
            assert_eq!(names, want, "from {p}");
        }
    }
}

// ---------------------------------------------------------------------------
// Random scenes against the brute-force reference.

/// Random rotated rectangles, one per 20 m grid square (so none overlap),
/// some split in two houses of different heights that share a wall, some
/// with a courtyard.
fn random_scene(rng: &mut ChaCha8Rng) -> Vec<Building> {
    let mut out = Vec::new();
    for gx in 0..5 {
        for gy in 0..5 {
            if rng.random_bool(0.3) {
                continue;
            }
            let c = DVec2::new(gx as f64 * 20.0 + 10.0, gy as f64 * 20.0 + 10.0);
            let (hx, hy) = (rng.random_range(2.0..8.0), rng.random_range(2.0..8.0));
            let angle: f64 = rng.random_range(0.0..std::f64::consts::PI);
            let (s, co) = angle.sin_cos();
            let rot = |p: DVec2| c + DVec2::new(p.x * co - p.y * s, p.x * s + p.y * co);
            let rect = |x0: f64, y0: f64, x1: f64, y1: f64| {
                vec![
                    rot(DVec2::new(x0, y0)),
                    rot(DVec2::new(x1, y0)),
                    rot(DVec2::new(x1, y1)),
                    rot(DVec2::new(x0, y1)),
                ]
            };
            let height = |rng: &mut ChaCha8Rng| {
                if rng.random_bool(0.1) {
                    rng.random_range(20.0..50.0)
                } else {
                    rng.random_range(1.0..12.0)
                }
            };
            let id = format!("{gx}-{gy}");
            let kind = rng.random_range(0..4);
            if kind == 2 {
                // An outline and a part of it (nested or sticking out), as in
                // OpenStreetMap: overlapping footprints.
                let (px, py) = (
                    rng.random_range(0.5..1.0) * hx,
                    rng.random_range(0.5..1.0) * hy,
                );
                let shift = if rng.random_bool(0.5) { 0.0 } else { 0.5 * hx };
                for (k, r) in [
                    rect(-hx, -hy, hx, hy),
                    rect(shift - px, -py, shift + px, py),
                ]
                .into_iter()
                .enumerate()
                {
                    out.push(Building {
                        id: format!("{id}:{k}"),
                        footprint: vec![Polygon {
                            exterior: r,
                            holes: vec![],
                        }],
                        height: height(rng),
                        occludes: true,
                    });
                }
            } else if kind == 0 {
                let split = rng.random_range(-0.5..0.5) * hx;
                for (k, (x0, x1)) in [(-hx, split), (split, hx)].into_iter().enumerate() {
                    out.push(Building {
                        id: format!("{id}/{k}"),
                        footprint: vec![Polygon {
                            exterior: rect(x0, -hy, x1, hy),
                            holes: vec![],
                        }],
                        height: height(rng),
                        occludes: true,
                    });
                }
            } else {
                let holes = if kind == 1 && hx > 4.0 && hy > 4.0 {
                    let mut h = rect(-hx + 2.0, -hy + 2.0, hx - 2.0, hy - 2.0);
                    h.reverse();
                    vec![h]
                } else {
                    vec![]
                };
                out.push(Building {
                    id,
                    footprint: vec![Polygon {
                        exterior: rect(-hx, -hy, hx, hy),
                        holes,
                    }],
                    height: height(rng),
                    occludes: true,
                });
            }
        }
    }
    out
}

#[test]
fn the_judge_agrees_with_brute_force_on_random_scenes() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut checked = 0;
    let mut seen_total = 0;
    for scene in 0..12 {
        let city = random_scene(&mut rng);
        let judge = Judge::new(&city);
        let mut scratch = Scratch::default();
        let mut views = 0;
        while views < 6 {
            let p = DVec3::new(
                rng.random_range(-10.0..110.0),
                rng.random_range(-10.0..110.0),
                if rng.random_bool(0.5) {
                    1.7
                } else {
                    rng.random_range(0.05..30.0)
                },
            );
            if city.iter().any(|b| {
                point_in_multipolygon(p.truncate(), &b.footprint)
                    || distance_to_outline(b, p.truncate()) < 0.01
            }) {
                continue;
            }
            views += 1;
            let View::Seen { sightings, .. } = judge.view(p, &mut scratch) else {
                panic!("scene {scene}: {p} is outside every building");
            };
            let mut judged: Vec<String> = sightings
                .iter()
                .map(|s| city[s.building as usize].id.clone())
                .collect();
            judged.sort();
            // Every sighting's witness is on its building's top outline and
            // joined to the viewpoint by a clear segment.
            for s in &sightings {
                let b = &city[s.building as usize];
                assert!((s.witness.z - b.height).abs() < 1e-12);
                assert!(
                    distance_to_outline(b, s.witness.truncate()) < 1e-6
                        || point_in_multipolygon(s.witness.truncate(), &b.footprint),
                    "scene {scene}, {p}: witness {} off {} by {}",
                    s.witness,
                    b.id,
                    distance_to_outline(b, s.witness.truncate())
                );
                assert!(
                    segment_clear(&city, p, s.witness),
                    "scene {scene}, {p}: witness {} of {} is blocked",
                    s.witness,
                    b.id
                );
            }
            // Everything brute force sees, the judge sees.
            let brute = brute_force_seen(&city, p, 0.1);
            let missed: Vec<&String> = brute.iter().filter(|id| !judged.contains(id)).collect();
            assert!(
                missed.is_empty(),
                "scene {scene}, {p}: judge missed {missed:?}"
            );
            checked += 1;
            seen_total += judged.len();
        }
    }
    assert_eq!(checked, 72);
    assert!(seen_total > 200, "the scenes are not trivial: {seen_total}");
}

/// The buildings seen from `p` (indices, ascending) and the rays walked.
fn seen_and_rays(judge: &Judge, p: DVec3, scratch: &mut Scratch) -> Option<(Vec<u32>, u64)> {
    match judge.view(p, scratch) {
        View::Seen {
            sightings, rays, ..
        } => Some((sightings.iter().map(|s| s.building).collect(), rays)),
        View::InsideBuilding { .. } => None,
    }
}

/// Wedges cut only as far as their walks reach give the verdicts of one
/// wedge between every two neighbouring vertex directions, from random
/// points of random scenes and of generated cities of both styles, at the
/// eye and above the roofs; and they walk fewer rays in a city.
#[test]
fn wedges_cut_as_far_as_the_walk_goes_keep_every_verdict() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let mut scenes: Vec<Vec<Building>> = (0..6).map(|_| random_scene(&mut rng)).collect();
    for style in [Style::Default, Style::OldTown] {
        scenes.push(generated_buildings(150, 4, style));
    }
    let (mut rays_cut, mut rays_every) = (0u64, 0u64);
    let mut compared = 0;
    for (k, city) in scenes.iter().enumerate() {
        let bounds = city
            .iter()
            .flat_map(|b| b.footprint.iter().flat_map(|p| p.exterior.iter()))
            .fold(citypvs::model::Rect::EMPTY, |mut r, p| {
                r.include(*p);
                r
            });
        let cut = Judge::new(city);
        let from_the_start = Judge::new(city).with_first_cuts_within(0.0);
        let every = Judge::new(city).with_first_cuts_within(f64::INFINITY);
        let mut scratch = Scratch::default();
        for _ in 0..25 {
            let p = DVec3::new(
                rng.random_range(bounds.min.x - 10.0..bounds.max.x + 10.0),
                rng.random_range(bounds.min.y - 10.0..bounds.max.y + 10.0),
                if rng.random_bool(0.5) {
                    1.7
                } else {
                    rng.random_range(0.05..40.0)
                },
            );
            let Some((want, rays)) = seen_and_rays(&every, p, &mut scratch) else {
                continue;
            };
            let (got, got_rays) = seen_and_rays(&cut, p, &mut scratch).unwrap();
            assert_eq!(got, want, "scene {k}, from {p}");
            let (got, _) = seen_and_rays(&from_the_start, p, &mut scratch).unwrap();
            assert_eq!(got, want, "scene {k}, from {p}, no first cuts");
            if k >= 6 {
                rays_cut += got_rays;
                rays_every += rays;
            }
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared} viewpoints compared");
    assert!(
        rays_cut < rays_every,
        "the cut wedges walked {rays_cut} rays, every vertex's {rays_every}"
    );
}

// ---------------------------------------------------------------------------
// Whole verdicts over cells.

/// A street between two rows, a low house hidden behind the south row, a
/// tower behind the north row, and four cells in the street.
fn street() -> (Vec<Building>, Vec<[DVec2; 3]>) {
    let city = vec![
        block("south", 0.0, -20.0, 100.0, -10.0, 10.0), // 0
        block("north", 0.0, 10.0, 100.0, 20.0, 10.0),   // 1
        block("hidden", 40.0, -40.0, 60.0, -30.0, 6.0), // 2
        block("tower", 40.0, 30.0, 60.0, 40.0, 80.0),   // 3
        block("end", 120.0, -10.0, 130.0, 10.0, 10.0),  // 4
    ];
    let q = |x: f64, y: f64| DVec2::new(x, y);
    let cells = vec![
        [q(0.0, -10.0), q(50.0, -10.0), q(0.0, 10.0)],
        [q(50.0, -10.0), q(50.0, 10.0), q(0.0, 10.0)],
        [q(50.0, -10.0), q(100.0, -10.0), q(50.0, 10.0)],
        [q(100.0, -10.0), q(100.0, 10.0), q(50.0, 10.0)],
    ];
    (city, cells)
}

fn options(cells: Option<usize>) -> VerifyOptions {
    VerifyOptions {
        cells,
        samples: 32,
        seed: 5,
    }
}

#[test]
fn an_exact_pvs_passes_and_a_broken_one_is_caught() {
    let (city, cells) = street();
    // Seen from the street: both rows, the tower over the north row, the end
    // house. Not the low house behind the south row.
    let exact = vec![vec![0, 1, 3, 4]; 4];
    let r = verify(&city, &cells, 1.7, &exact, &options(None));
    assert!(r.violations.is_empty(), "{:?}", r.violations);
    assert_eq!(r.cells_checked, 4);
    assert_eq!(r.viewpoints, 4 * 32);
    assert!(r.blocked_viewpoints.is_empty());
    assert!((r.mean_tightness - 1.0).abs() < 1e-12 && (r.worst_tightness - 1.0).abs() < 1e-12);
    assert!((r.seen_fraction - 1.0).abs() < 1e-12);
    assert!(r.rays > 0);

    // Cell 2 forgets the tower.
    let mut broken = exact.clone();
    broken[2] = vec![0, 1, 4];
    let r = verify(&city, &cells, 1.7, &broken, &options(None));
    assert_eq!(r.violations.len(), 1, "{:?}", r.violations);
    let v = &r.violations[0];
    assert_eq!((v.cell, v.building.as_str()), (2, "tower"));
    // The viewpoint is in cell 2's prism, the witness on the tower's top.
    let p = DVec2::new(v.viewpoint[0], v.viewpoint[1]);
    assert!(p.x >= 50.0 - 1e-9 && p.x <= 100.0 + 1e-9 && p.y.abs() <= 10.0 + 1e-9);
    assert!(v.viewpoint[2] > 0.0 && v.viewpoint[2] <= 1.7);
    assert!((v.witness[2] - 80.0).abs() < 1e-12);
    assert!(v.witness[0] >= 40.0 - 1e-9 && v.witness[0] <= 60.0 + 1e-9);
    assert!(segment_clear(
        &city,
        DVec3::from_array(v.viewpoint),
        DVec3::from_array(v.witness)
    ));
    assert_eq!(r.cells[2].missing, 1);

    // A superset (everything everywhere) passes, with a looser tightness.
    let all = vec![vec![0, 1, 2, 3, 4]; 4];
    let r = verify(&city, &cells, 1.7, &all, &options(None));
    assert!(r.violations.is_empty());
    assert!((r.mean_tightness - 1.25).abs() < 1e-12);
    assert!((r.seen_fraction - 0.8).abs() < 1e-12);
}

#[test]
fn verdicts_repeat_for_a_seed_and_any_thread_count() {
    let (city, cells) = street();
    let broken = vec![vec![0, 1], vec![0, 1, 3], vec![1, 3, 4], vec![]];
    let run = |threads: usize, cells_k: Option<usize>| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let r = pool.install(|| verify(&city, &cells, 1.7, &broken, &options(cells_k)));
        serde_json::to_value(r.violations).unwrap().to_string()
            + &serde_json::to_value(r.cells).unwrap().to_string()
    };
    let one = run(1, None);
    assert_eq!(one, run(3, None));
    assert!(one.contains("\"tower\"") && one.contains("\"end\""));
    // Two cells drawn at random: a subset of the full verdict's cells.
    let two = run(2, Some(2));
    assert_eq!(two, run(1, Some(2)));
    assert_ne!(two, one);
}

#[test]
fn lower_viewpoints_see_no_more_than_the_eye() {
    // Height monotonicity (docs/METHOD.md §3) holds for the judge's answers.
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let city = random_scene(&mut rng);
    let judge = Judge::new(&city);
    let mut scratch = Scratch::default();
    let mut compared = 0;
    for _ in 0..40 {
        let p = DVec2::new(rng.random_range(0.0..100.0), rng.random_range(0.0..100.0));
        if city.iter().any(|b| point_in_multipolygon(p, &b.footprint)) {
            continue;
        }
        let set = |z: f64, scratch: &mut Scratch| match judge.view(p.extend(z), scratch) {
            View::Seen { sightings, .. } => {
                sightings.iter().map(|s| s.building).collect::<Vec<_>>()
            }
            View::InsideBuilding { .. } => unreachable!(),
        };
        let high = set(1.7, &mut scratch);
        let low = set(0.05, &mut scratch);
        assert!(
            low.iter().all(|b| high.contains(b)),
            "{p}: {low:?} vs {high:?}"
        );
        compared += 1;
    }
    assert!(compared > 20);
}
