//! Free space where a viewer fits (`min_gap`): passages at least min_gap
//! wide keep cells, narrower ones lose them, cells stay clear of every
//! footprint, occluders never change, and sight lines still pass through
//! slits that no viewer fits in. Also the old-town style's cell quality.

use crate::common::block;
use citypvs::cells::{CellParams, triangulate_exact};
use citypvs::geometry::merge_blocks;
use citypvs::model::{Building, Polygon, distance_to_segment, point_in_multipolygon};
use citypvs::prepare::prepare;
use glam::DVec2;
use proptest::prelude::*;

const MIN_GAP: f64 = 0.5;

fn params(min_gap: f64) -> CellParams {
    CellParams {
        margin: 10.0,
        max_edge: 10.0,
        region: None,
        min_gap,
    }
}

fn rotate(b: &Building, angle: f64) -> Building {
    let r = DVec2::from_angle(angle);
    let mut out = b.clone();
    for p in &mut out.footprint {
        for v in p.exterior.iter_mut().chain(p.holes.iter_mut().flatten()) {
            *v = r.rotate(*v);
        }
    }
    out
}

/// Two 20 m long buildings with a corridor of width `w` between them
/// (y from 10 to 10 + w), rotated by `angle`.
fn corridor(w: f64, angle: f64) -> Vec<Building> {
    [
        block("south", 0.0, 0.0, 20.0, 10.0, 10.0),
        block("north", 0.0, 10.0 + w, 20.0, 20.0 + w, 10.0),
    ]
    .iter()
    .map(|b| rotate(b, angle))
    .collect()
}

/// Area of the cells whose centroid lies in the corridor, away from its
/// two mouths.
fn corridor_cell_area(cells: &[[DVec2; 3]], w: f64, angle: f64) -> f64 {
    let back = DVec2::from_angle(-angle);
    cells
        .iter()
        .filter(|t| {
            let c = back.rotate((t[0] + t[1] + t[2]) / 3.0);
            (1.0..19.0).contains(&c.x) && (10.0..10.0 + w).contains(&c.y)
        })
        .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]))
        .sum()
}

/// Every cell corner is outside every footprint and at least `clear` from
/// every footprint edge.
fn assert_clear(cells: &[[DVec2; 3]], buildings: &[Building], clear: f64) {
    let footprints: Vec<Polygon> = buildings.iter().flat_map(|b| b.footprint.clone()).collect();
    for t in cells {
        for &v in t {
            assert!(
                !point_in_multipolygon(v, &footprints),
                "{v} inside a footprint"
            );
            for p in &footprints {
                let n = p.exterior.len();
                for i in 0..n {
                    let d = distance_to_segment(v, p.exterior[i], p.exterior[(i + 1) % n]);
                    assert!(d >= clear, "{v} is {d} m from a wall");
                }
            }
        }
    }
}

#[test]
fn passages_just_wider_than_min_gap_keep_cells_narrower_ones_lose_them() {
    // 11.25 degrees is the worst direction for the 16-sided structuring
    // polygon (2% wider there).
    for angle in [0.0, 0.3, 11.25f64.to_radians(), 1.0] {
        let wide = corridor(MIN_GAP * 1.06, angle);
        let cells = triangulate_exact(&merge_blocks(&wide), &params(MIN_GAP)).unwrap();
        let area = corridor_cell_area(&cells.triangles, MIN_GAP * 1.06, angle);
        // The corridor is 18 m long here; all but a few millimetres kept.
        assert!(
            area > 0.95 * 18.0 * MIN_GAP * 1.06,
            "angle {angle}: only {area} m2 of cells in the wide passage"
        );
        assert_clear(&cells.triangles, &wide, 0.9e-3);

        let narrow = corridor(MIN_GAP * 0.94, angle);
        let cells = triangulate_exact(&merge_blocks(&narrow), &params(MIN_GAP)).unwrap();
        let area = corridor_cell_area(&cells.triangles, MIN_GAP * 0.94, angle);
        assert_eq!(area, 0.0, "angle {angle}: cells in the narrow passage");
        assert_clear(&cells.triangles, &narrow, 0.9e-3);
        // Without a minimum gap the narrow passage has cells.
        let all = triangulate_exact(&merge_blocks(&narrow), &params(0.0)).unwrap();
        assert!(corridor_cell_area(&all.triangles, MIN_GAP * 0.94, angle) > 5.0);
    }
}

/// A passage into a yard gets cells about as thick as it is wide, and
/// at most about two per width of its length: the refinement splits a wall
/// wherever a vertex of the other wall encroaches on it (comes into its
/// diametral circle), whatever its angle limit (3 degrees). Measured 34,
/// 16 and 10 cells, at least 0.62, 1.5 and 1.4 m thick.
#[test]
fn passages_get_few_thick_cells() {
    for (w, angle) in [(0.8, 0.3), (1.5, 0.0), (3.0, 1.0)] {
        // Two 20 m long buildings 3 m apart along the passage, so that no
        // vertex of one wall faces one of the other: 17 m of passage.
        let city: Vec<Building> = [
            block("south", 0.0, 0.0, 20.0, 10.0, 10.0),
            block("north", 3.0, 10.0 + w, 23.0, 20.0 + w, 10.0),
        ]
        .iter()
        .map(|b| rotate(b, angle))
        .collect();
        let params = CellParams {
            max_edge: 30.0,
            ..params(MIN_GAP)
        };
        let cells = triangulate_exact(&merge_blocks(&city), &params).unwrap();
        let back = DVec2::from_angle(-angle);
        let inside: Vec<&[DVec2; 3]> = cells
            .triangles
            .iter()
            .filter(|t| {
                let c = back.rotate((t[0] + t[1] + t[2]) / 3.0);
                (3.0..20.0).contains(&c.x) && (10.0..10.0 + w).contains(&c.y)
            })
            .collect();
        let thinnest = inside
            .iter()
            .map(|t| {
                let area = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
                let longest = (0..3)
                    .map(|k| t[k].distance(t[(k + 1) % 3]))
                    .fold(0.0, f64::max);
                area / longest
            })
            .fold(f64::INFINITY, f64::min);
        assert!(!inside.is_empty());
        assert!(
            thinnest > 0.3 * w,
            "passage {w} m: a cell {thinnest} m thin"
        );
        assert!(
            (inside.len() as f64) <= 2.0 * 17.0 / w + 2.0,
            "passage {w} m: {} cells",
            inside.len()
        );
    }
}

#[test]
fn occluders_do_not_change_and_sight_passes_through_a_slit() {
    // A long wall of two buildings with a 0.3 m slit in the middle, and a
    // low house behind it, seen only through the slit.
    let buildings = vec![
        block("west", -60.0, 0.0, -0.15, 4.0, 20.0),
        block("east", 0.15, 0.0, 60.0, 4.0, 20.0),
        block("house", -2.0, 30.0, 2.0, 34.0, 6.0),
    ];
    let city = |bs: &[Building]| citypvs::input::City {
        buildings: bs.to_vec(),
        frame: citypvs::input::Frame::Metric {
            origin: DVec2::ZERO,
            crs: None,
        },
        source_hash: [0; 32],
        report: Default::default(),
    };
    let at = |g: f64| {
        prepare(
            city(&buildings),
            &citypvs::Settings::new(citypvs::RawSettings {
                margin: Some(10.0),
                max_cell_edge: Some(4.0),
                min_gap: Some(g),
                ..Default::default()
            })
            .unwrap(),
        )
        .unwrap()
    };
    let (open, kept) = (at(0.0), at(MIN_GAP));
    let shapes = |s: &citypvs::prepare::Scene| {
        s.occluders
            .iter()
            .map(|o| (o.block, o.level, o.shape.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(shapes(&open), shapes(&kept));
    // No cell in the slit with the minimum gap.
    assert!(kept.cells.triangles.iter().all(|t| {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        !(c.x.abs() < 0.15 && (0.0..4.0).contains(&c.y))
    }));
    // The cells right in front of the slit see the house through it.
    let visible = citypvs::visibility::VisibilityEngine::new(&kept)
        .unwrap()
        .solve_all(&|_| {})
        .unwrap();
    let mut checked = 0;
    for (t, visible) in kept.cells.triangles.iter().zip(&visible) {
        let c = (t[0] + t[1] + t[2]) / 3.0;
        if c.x.abs() < 1.0 && (-3.0..0.0).contains(&c.y) {
            assert!(visible.contains(&2), "cell at {c} misses the house");
            checked += 1;
        }
    }
    assert!(checked > 0);
}

#[test]
fn old_town_cells_are_rarely_thin() {
    use citypvs::generate::{GenerateParams, Style, generate_geojson_styled};
    let params = GenerateParams {
        buildings: 2000,
        seed: 3,
    };
    let text = generate_geojson_styled(&params, Style::OldTown);
    let options = citypvs::input::InputOptions::default();
    let city = citypvs::input::read_city_bytes(text.as_bytes(), "old-town", &options).unwrap();
    let scene = prepare(city.clone(), &citypvs::Settings::default()).unwrap();
    let summary = citypvs::prepare::summary(&scene);
    assert_eq!(summary.buildings, 2000);
    assert!(
        summary.thin_cells as f64 <= 0.01 * summary.cells as f64,
        "{} of {} cells thinner than 5 cm",
        summary.thin_cells,
        summary.cells
    );
    assert!(summary.dropped_area_m2 > 0.0);
    // No cell corner deeper inside a footprint than the grid moves it.
    let mut grid: std::collections::HashMap<(i64, i64), Vec<DVec2>> = Default::default();
    let key = |p: DVec2| ((p.x / 10.0).floor() as i64, (p.y / 10.0).floor() as i64);
    for t in &scene.cells.triangles {
        for &v in t {
            grid.entry(key(v)).or_default().push(v);
        }
    }
    for b in &scene.city.buildings {
        let r = citypvs::model::multipolygon_bounds(&b.footprint).grown(0.01);
        let (k0, k1) = (key(r.min), key(r.max));
        for kx in k0.0..=k1.0 {
            for ky in k0.1..=k1.1 {
                for &v in grid.get(&(kx, ky)).into_iter().flatten() {
                    // The exact corners keep 0.9 mm from every wall (the
                    // corridor tests); on the 1/256 m grid a corner may
                    // move up to the snap distance, never farther in.
                    let mut nearest = f64::INFINITY;
                    for p in &b.footprint {
                        for ring in std::iter::once(&p.exterior).chain(p.holes.iter()) {
                            for i in 0..ring.len() {
                                let d = distance_to_segment(v, ring[i], ring[(i + 1) % ring.len()]);
                                nearest = nearest.min(d);
                            }
                        }
                    }
                    assert!(
                        !point_in_multipolygon(v, &b.footprint)
                            || nearest <= citypvs::pvs::mesh::SNAP_DISTANCE,
                        "{v} is {nearest} m inside {}",
                        b.id
                    );
                }
            }
        }
    }
    // Without the minimum gap the same city is full of slivers.
    let raw = citypvs::Settings::new(citypvs::RawSettings {
        min_gap: Some(0.0),
        ..Default::default()
    })
    .unwrap();
    let all = citypvs::prepare::summary(&prepare(city, &raw).unwrap());
    assert!(all.thin_cells as f64 > 0.5 * all.cells as f64);
    assert!(summary.cells * 3 < all.cells);
    // Cells per free area against the default style at the same settings.
    let default_text = citypvs::generate::generate_geojson(&params);
    let default_city =
        citypvs::input::read_city_bytes(default_text.as_bytes(), "default", &options).unwrap();
    let d =
        citypvs::prepare::summary(&prepare(default_city, &citypvs::Settings::default()).unwrap());
    let expected = summary.free_area_m2 / (d.free_area_m2 / d.cells as f64);
    let ratio = summary.cells as f64 / expected;
    eprintln!(
        "old town: {} cells, {ratio:.2} x the default style's density",
        summary.cells
    );
    // Measured 1.18-1.21 on seeds 1-3 (1.18 on this one; 1.9 with a 20
    // degree refinement angle): what is left is mostly the passages into
    // the yards and the light wells, whose cells are as small as they are.
    assert!(ratio < 1.25, "{ratio}");
}

/// A row of buildings sharing walls drawn with gaps and overlaps.
fn row(widths: &[f64], offsets: &[(f64, f64)]) -> Vec<Building> {
    let mut x = 0.0;
    let mut out = Vec::new();
    for (i, (&w, &(dx, dy))) in widths.iter().zip(offsets).enumerate() {
        out.push(block(&format!("b{i}"), x + dx, dy, x + w, 12.0 + dy, 10.0));
        x += w;
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn misaligned_rows_give_clear_cells_without_slivers(
        widths in prop::collection::vec(4.0f64..12.0, 2..7),
        offsets in prop::collection::vec((-0.2f64..0.2, -0.05f64..0.05), 7),
        angle in 0.0f64..1.6,
    ) {
        let buildings: Vec<Building> = row(&widths, &offsets)
            .iter()
            .map(|b| rotate(b, angle))
            .collect();
        let cells = triangulate_exact(&merge_blocks(&buildings), &params(MIN_GAP)).unwrap();
        assert_clear(&cells.triangles, &buildings, 0.9e-3);
        let thin = cells
            .triangles
            .iter()
            .filter(|t| citypvs::prepare::triangle_altitude(t) < 0.05)
            .count();
        prop_assert!(thin == 0, "{} thin cells of {}", thin, cells.triangles.len());
        // Cells do not overlap: their areas add up to the kept free area,
        // which is at most the free area.
        let area: f64 = cells.triangles.iter().map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0])).sum();
        prop_assert!(cells.triangles.iter().all(|t| (t[1] - t[0]).perp_dot(t[2] - t[0]) > 0.0));
        prop_assert!(area <= cells.open_area + 1e-6);
    }
}

#[test]
fn render_shows_the_dropped_gaps() {
    use citypvs::render::{Picture, render};
    let buildings = corridor(MIN_GAP * 0.9, 0.0);
    let scene = prepare(
        super::common::metric_city(buildings),
        &citypvs::Settings::default(),
    )
    .unwrap();
    assert!(!scene.cells.dropped.is_empty());
    let picture = Picture {
        scene: &scene,
        focus: None,
        cull_map: None,
        pvs_sizes: None,
        view: None,
        width: 3000,
    };
    let mut r = render(&picture).unwrap();
    let middle = DVec2::new(10.0, 10.0 + MIN_GAP * 0.45);
    assert_ne!(r.colour_at(middle), Some(citypvs::render::palette::DROPPED));
    r.overlay_dropped(&scene);
    assert_eq!(r.colour_at(middle), Some(citypvs::render::palette::DROPPED));
    assert!(!r.png().unwrap().is_empty());
}
