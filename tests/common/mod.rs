//! Helpers shared by the integration tests: hand-made scenes.
#![allow(dead_code)]

use citypvs::cells::Cells;
use citypvs::geometry::Occluder;
use citypvs::input::{City, Frame, InputReport};
use citypvs::model::{Building, Polygon};
use citypvs::prepare::Scene;
use glam::DVec2;

/// A counter-clockwise axis-aligned rectangle.
pub fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<DVec2> {
    vec![
        DVec2::new(x0, y0),
        DVec2::new(x1, y0),
        DVec2::new(x1, y1),
        DVec2::new(x0, y1),
    ]
}

/// A building with a rectangular footprint.
pub fn block(id: &str, x0: f64, y0: f64, x1: f64, y1: f64, height: f64) -> Building {
    Building {
        id: id.into(),
        footprint: vec![Polygon {
            exterior: rect(x0, y0, x1, y1),
            holes: vec![],
        }],
        height,
        occludes: true,
    }
}

/// A square ring building (courtyard of half-size `inner` inside half-size `outer`) centred at `c`.
pub fn ring_building(id: &str, c: DVec2, outer: f64, inner: f64, height: f64) -> Building {
    let mut hole = rect(c.x - inner, c.y - inner, c.x + inner, c.y + inner);
    hole.reverse();
    Building {
        id: id.into(),
        footprint: vec![Polygon {
            exterior: rect(c.x - outer, c.y - outer, c.x + outer, c.y + outer),
            holes: vec![hole],
        }],
        height,
        occludes: true,
    }
}

/// Exact erosion of axis-aligned rectangles and square rings (no reflex
/// corners on the exterior; the ring's hole grows by eps).
pub fn shrink_axis_aligned(b: &Building, eps: f64) -> Vec<Polygon> {
    b.footprint
        .iter()
        .filter_map(|p| {
            let (min, max) = bounds(&p.exterior);
            if max.x - min.x <= 2.0 * eps || max.y - min.y <= 2.0 * eps {
                return None;
            }
            let holes = p
                .holes
                .iter()
                .map(|h| {
                    let (hmin, hmax) = bounds(h);
                    let mut r = rect(hmin.x - eps, hmin.y - eps, hmax.x + eps, hmax.y + eps);
                    r.reverse();
                    r
                })
                .collect();
            Some(Polygon {
                exterior: rect(min.x + eps, min.y + eps, max.x - eps, max.y - eps),
                holes,
            })
        })
        .collect()
}

fn bounds(ring: &[DVec2]) -> (DVec2, DVec2) {
    let mut min = DVec2::splat(f64::INFINITY);
    let mut max = DVec2::splat(f64::NEG_INFINITY);
    for p in ring {
        min = min.min(*p);
        max = max.max(*p);
    }
    (min, max)
}

/// A scene of separate (non-touching) axis-aligned buildings and the given
/// cells, with occluders shrunk by hand, bypassing merge and triangulation.
pub fn hand_scene(buildings: Vec<Building>, cells: Vec<[DVec2; 3]>, eps: f64) -> Scene {
    let occluders = buildings
        .iter()
        .enumerate()
        .map(|(i, b)| Occluder {
            block: i,
            level: 0,
            height: b.height,
            shape: shrink_axis_aligned(b, eps),
        })
        .filter(|o| !o.shape.is_empty())
        .collect();
    Scene {
        city: metric_city(buildings),
        blocks: vec![],
        occluders,
        cells: Cells {
            triangles: cells,
            region: Polygon::default(),
            open_area: 0.0,
            dropped: vec![],
            min_gap: 0.0,
        },
        settings: citypvs::Settings::new(citypvs::RawSettings {
            eps: Some(eps),
            ..Default::default()
        })
        .expect("valid eps"),
        timings: vec![],
    }
}

/// A city of `buildings` already in local metres (origin at 0, 0).
pub fn metric_city(buildings: Vec<Building>) -> City {
    City {
        buildings,
        frame: Frame::Metric {
            origin: DVec2::ZERO,
            crs: None,
        },
        source_hash: [0; 32],
        report: InputReport::default(),
    }
}

/// A small counter-clockwise triangle around `c`.
pub fn cell_at(c: DVec2, size: f64) -> [DVec2; 3] {
    [
        c + DVec2::new(-size, -size),
        c + DVec2::new(size, -size),
        c + DVec2::new(0.0, size),
    ]
}

/// Run the `citypvs` binary in `dir`.
pub fn citypvs(dir: &std::path::Path, args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run citypvs")
}

/// A finished command's standard error as text.
pub fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The offsets of the header's numbers in a `.pvs` file (docs/FORMAT.md).
pub const HEADER_EPS: usize = 24;
pub const HEADER_EYE_HEIGHT: usize = 32;
pub const HEADER_PIXEL: usize = 40;
pub const HEADER_MAX_CELL_EDGE: usize = 48;
pub const HEADER_MARGIN: usize = 56;

/// A `.pvs` file's bytes with the f64 at `offset` of the header replaced
/// and the checksum recomputed, so a header no writer would produce reaches
/// the reader's checks (the writer refuses to write one).
pub fn with_header_number(mut bytes: Vec<u8>, offset: usize, value: f64) -> Vec<u8> {
    use sha2::{Digest, Sha256};
    bytes[offset..offset + 8].copy_from_slice(&value.to_le_bytes());
    let body = bytes.len() - 32;
    let sum: [u8; 32] = Sha256::digest(&bytes[..body]).into();
    bytes[body..].copy_from_slice(&sum);
    bytes
}

/// The message of `result`'s error, after checking that the error is of
/// `kind` (tests match the kind, then what the message names).
pub fn error_of<T>(result: citypvs::Result<T>, kind: citypvs::ErrorKind) -> String {
    let Err(err) = result else {
        panic!("an error of kind {kind:?} was expected");
    };
    assert_eq!(err.kind(), &kind, "{err}");
    err.to_string()
}

/// A metric GeoJSON city of `n` 1 m squares, 4 m apart, 5 m high: they all
/// erode to nothing, so every cell sees every building.
pub fn tiny_city(n: usize) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let features: Vec<String> = (0..n)
        .map(|k| {
            let (x, y) = ((k % side) as f64 * 4.0, (k / side) as f64 * 4.0);
            let ring: Vec<String> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.0, 0.0)]
                .iter()
                .map(|(dx, dy)| format!("[{},{}]", x + dx, y + dy))
                .collect();
            format!(
                r#"{{"type":"Feature","properties":{{"id":"t{k}","height":5}},"geometry":{{"type":"Polygon","coordinates":[[{}]]}}}}"#,
                ring.join(",")
            )
        })
        .collect();
    format!(
        r#"{{"type":"FeatureCollection","features":[{}]}}"#,
        features.join(",")
    )
}

/// Run `citypvs ARGS --json` in `dir`, require success, and return the
/// JSON summary it printed.
pub fn citypvs_json(dir: &std::path::Path, args: &[&str]) -> serde_json::Value {
    let mut all = args.to_vec();
    all.push("--json");
    let out = citypvs(dir, &all);
    assert!(out.status.success(), "{}", stderr(&out));
    serde_json::from_slice(&out.stdout).expect("a JSON summary")
}

/// The buildings of a generated city in the given style, in local metres,
/// every one an occluder.
pub fn generated_buildings(
    buildings: usize,
    seed: u64,
    style: citypvs::generate::Style,
) -> Vec<Building> {
    use citypvs::generate::{GenerateParams, generate_styled};
    generate_styled(&GenerateParams { buildings, seed }, style)
        .buildings
        .into_iter()
        .map(|g| Building {
            id: g.id,
            footprint: vec![g.footprint],
            height: g.height,
            occludes: true,
        })
        .collect()
}

/// The prepared scene of a generated city at the default settings.
pub fn generated_scene(buildings: usize, seed: u64) -> Scene {
    use citypvs::generate::{GenerateParams, generate_geojson};
    let geojson = generate_geojson(&GenerateParams { buildings, seed });
    let city = citypvs::input::read_city_bytes(
        geojson.as_bytes(),
        &format!("generated-{seed}"),
        &citypvs::input::InputOptions::default(),
    )
    .expect("read generated city");
    citypvs::prepare::prepare(city, &citypvs::Settings::default()).expect("prepare")
}

/// The bake numbers the format tests write into their headers.
pub fn test_numbers() -> citypvs::BakeNumbers {
    citypvs::BakeNumbers {
        eps: 0.25,
        eye_height: 1.7,
        pixel: 0.125,
        max_cell_edge: 20.0,
        margin: 30.0,
        near_field: 48.0,
        min_gap: 0.0,
    }
}
