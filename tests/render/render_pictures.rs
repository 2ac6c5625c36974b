//! Pictures of hand-made scenes: the colours at known places of
//! the map follow the visible sets, the cull map and the PVS sizes.

use crate::common::*;
use citypvs::model::Rect;
use citypvs::prepare::Scene;
use citypvs::render::palette::{self, Rgb};
use citypvs::render::{Focus, Picture, Rendered, cell_containing, render, view_around};
use citypvs::visibility::VisibilityEngine;
use glam::DVec2;

const WALL: usize = 0;
const HOUSE: usize = 1;
const SIDE: usize = 2;

/// A tall wall north of cell 0 hides a low house behind it; a low shed
/// south-east of the cell is in the open. Cell 1 stands east of the wall's
/// end and sees past it.
fn street() -> Scene {
    hand_scene(
        vec![
            block("wall", -40.0, 10.0, 40.0, 14.0, 20.0),
            block("house", -5.0, 30.0, 5.0, 40.0, 8.0),
            block("side", 20.0, -20.0, 30.0, -10.0, 6.0),
        ],
        vec![
            cell_at(DVec2::ZERO, 3.0),
            cell_at(DVec2::new(55.0, 22.0), 3.0),
        ],
        1.0,
    )
}

fn all_sets(scene: &Scene) -> Vec<Vec<u32>> {
    VisibilityEngine::new(scene)
        .unwrap()
        .solve_all(&|_| {})
        .unwrap()
}

fn cull_map(scene: &Scene, cell: usize, radius: f64) -> citypvs::visibility::CullMapImage {
    VisibilityEngine::new(scene)
        .unwrap()
        .cull_map(cell, radius)
        .unwrap()
}

fn centre(scene: &Scene, b: usize) -> DVec2 {
    let ring = &scene.city.buildings[b].footprint[0].exterior;
    ring.iter().copied().sum::<DVec2>() / ring.len() as f64
}

fn cell_centre(scene: &Scene, c: usize) -> DVec2 {
    let t = scene.cells.triangles[c];
    (t[0] + t[1] + t[2]) / 3.0
}

fn picture(scene: &Scene) -> Picture<'_> {
    Picture {
        scene,
        focus: None,
        cull_map: None,
        pvs_sizes: None,
        view: None,
        width: 400,
    }
}

fn at(r: &Rendered, p: DVec2) -> Rgb {
    r.colour_at(p).expect("point on the map")
}

fn brightness(c: Rgb) -> u32 {
    c.0 as u32 + c.1 as u32 + c.2 as u32
}

#[test]
fn chosen_cell_shows_visible_and_culled_buildings_apart() {
    let scene = street();
    let focus = Focus::compute(&scene, 0).unwrap();
    assert!(focus.sees(WALL) && focus.sees(SIDE) && !focus.sees(HOUSE));
    let r = render(&Picture {
        focus: Some(&focus),
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(at(&r, centre(&scene, WALL)), palette::VISIBLE);
    assert_eq!(at(&r, centre(&scene, SIDE)), palette::VISIBLE);
    assert_eq!(at(&r, centre(&scene, HOUSE)), palette::CULLED);
    assert_eq!(at(&r, cell_centre(&scene, 0)), palette::CHOSEN_CELL);
    // The other cell is plain free space.
    assert_eq!(at(&r, cell_centre(&scene, 1)), palette::FREE_SPACE);
    // Sample points are dark dots on the cell's corners.
    let corner = scene.cells.triangles[0][2];
    assert!(brightness(at(&r, corner)) < 150, "{:?}", at(&r, corner));
    let t = scene.cells.triangles[0];
    assert!(focus.samples.len() > 3);
    for s in &focus.samples {
        let on_edge =
            (0..3).any(|k| citypvs::model::distance_to_segment(*s, t[k], t[(k + 1) % 3]) < 1e-9);
        assert!(on_edge, "sample {s} is on the cell's boundary");
    }
}

#[test]
fn one_cell_computed_alone_sees_what_the_bake_gives_it() {
    let scene = street();
    let all = all_sets(&scene);
    for (c, expected) in all.iter().enumerate() {
        assert_eq!(&Focus::compute(&scene, c).unwrap().visible, expected);
    }
}

#[test]
fn colours_follow_the_given_visible_set() {
    let scene = street();
    // A set as if read from a .pvs file: only the house.
    let focus = Focus::new(&scene, 1, vec![HOUSE as u32]).unwrap();
    let r = render(&Picture {
        focus: Some(&focus),
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(at(&r, centre(&scene, HOUSE)), palette::VISIBLE);
    assert_eq!(at(&r, centre(&scene, WALL)), palette::CULLED);
    assert_eq!(at(&r, cell_centre(&scene, 1)), palette::CHOSEN_CELL);
    assert_eq!(at(&r, cell_centre(&scene, 0)), palette::FREE_SPACE);
}

#[test]
fn cull_map_heat_lies_where_the_wall_shadows() {
    let scene = street();
    let focus = Focus::compute(&scene, 0).unwrap();
    let image = cull_map(&scene, 0, 60.0);
    let f_at = |q: DVec2| {
        let i = ((q.x - image.origin.x) / image.pixel).floor() as usize;
        let j = ((q.y - image.origin.y) / image.pixel).floor() as usize;
        image.heights[j * image.width + i] as f64
    };
    let behind = DVec2::new(-20.0, 22.0);
    let open = DVec2::new(-20.0, -8.0);
    assert!(f_at(behind) > 0.0);
    assert_eq!(f_at(open), 0.0);
    let r = render(&Picture {
        focus: Some(&focus),
        cull_map: Some(&image),
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(at(&r, behind), palette::CULL_RAMP.step(f_at(behind) / 20.0));
    assert_eq!(at(&r, open), palette::OUTSIDE);
    // Buildings stay on top of the heat.
    assert_eq!(at(&r, centre(&scene, HOUSE)), palette::CULLED);
    // The shrunk wall's southern edge (y = 11) is outlined: darker than the
    // wall's fill a little further in.
    let edge = at(&r, DVec2::new(0.0, 11.0));
    let fill = at(&r, DVec2::new(0.0, 12.5));
    assert_eq!(fill, palette::VISIBLE);
    assert!(brightness(edge) + 150 < brightness(fill), "{edge:?}");
    // Without the cull map the same place is plain.
    let plain = render(&Picture {
        focus: Some(&focus),
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(at(&plain, behind), palette::OUTSIDE);
}

#[test]
fn png_keeps_the_map_colours_exactly() {
    let scene = street();
    let focus = Focus::compute(&scene, 0).unwrap();
    let image = cull_map(&scene, 0, 60.0);
    let r = render(&Picture {
        focus: Some(&focus),
        cull_map: Some(&image),
        ..picture(&scene)
    })
    .unwrap();
    let back = tiny_skia::Pixmap::decode_png(&r.png().unwrap()).unwrap();
    assert_eq!(
        (back.width(), back.height()),
        (r.pixmap.width(), r.pixmap.height())
    );
    for q in [
        centre(&scene, WALL),
        centre(&scene, HOUSE),
        cell_centre(&scene, 0),
        DVec2::new(-20.0, 22.0),
        DVec2::new(-20.0, -8.0),
    ] {
        let (x, y) = r.viewport.pixel_of(q).unwrap();
        let c = back.pixel(x, y).unwrap().demultiply();
        assert_eq!(Rgb(c.red(), c.green(), c.blue()), at(&r, q), "at {q}");
    }
}

#[test]
fn pvs_size_heat_map_colours_each_cell_by_its_set_size() {
    let scene = street();
    let sizes: Vec<usize> = all_sets(&scene).iter().map(Vec::len).collect();
    assert_ne!(sizes[0], sizes[1], "the two cells see different sets");
    let (lo, hi) = (*sizes.iter().min().unwrap(), *sizes.iter().max().unwrap());
    let r = render(&Picture {
        pvs_sizes: Some(&sizes),
        ..picture(&scene)
    })
    .unwrap();
    for (c, &size) in sizes.iter().enumerate() {
        let t = (size - lo) as f64 / (hi - lo) as f64;
        assert_eq!(at(&r, cell_centre(&scene, c)), palette::PVS_RAMP.step(t));
    }
    assert_eq!(at(&r, centre(&scene, HOUSE)), palette::NEUTRAL_BUILDING);
}

#[test]
fn whole_city_map_shades_taller_buildings_darker() {
    let scene = street();
    let r = render(&picture(&scene)).unwrap();
    let wall = at(&r, centre(&scene, WALL));
    let side = at(&r, centre(&scene, SIDE));
    assert_eq!(wall, palette::HEIGHT_RAMP.step(1.0));
    assert!(brightness(wall) < brightness(side));
    assert_eq!(at(&r, cell_centre(&scene, 0)), palette::FREE_SPACE);
    // The legend panel is below the map and has ink on it.
    assert!(r.pixmap.height() > r.viewport.height);
    let inked = (r.viewport.height + 2..r.pixmap.height())
        .flat_map(|y| (0..r.pixmap.width()).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let c = r.pixmap.pixel(x, y).unwrap();
            (c.red() as u32 + c.green() as u32 + c.blue() as u32) < 200
        })
        .count();
    assert!(inked > 200, "{inked} dark pixels in the legend");
    // The narrowest picture still has its map and legend.
    let small = render(&Picture {
        width: citypvs::render::MIN_SIZE,
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(small.pixmap.width(), citypvs::render::MIN_SIZE);
    assert!(small.pixmap.height() > small.viewport.height);
    assert_eq!(
        at(&small, centre(&scene, WALL)),
        palette::HEIGHT_RAMP.step(1.0)
    );
}

#[test]
fn zoomed_view_shows_only_the_square_around_the_cell() {
    let scene = street();
    let view = view_around(&scene, 0, 8.0);
    let r = render(&Picture {
        view: Some(view),
        ..picture(&scene)
    })
    .unwrap();
    assert_eq!(r.viewport.width, 400);
    assert!((r.viewport.scale - 400.0 / 16.0).abs() < 1e-9);
    assert!(r.colour_at(centre(&scene, HOUSE)).is_none());
    assert_eq!(at(&r, cell_centre(&scene, 0)), palette::FREE_SPACE);
}

#[test]
fn same_picture_gives_the_same_bytes() {
    let scene = street();
    let focus = Focus::compute(&scene, 0).unwrap();
    let image = cull_map(&scene, 0, 40.0);
    let draw = || {
        render(&Picture {
            focus: Some(&focus),
            cull_map: Some(&image),
            ..picture(&scene)
        })
        .unwrap()
        .png()
        .unwrap()
    };
    let (a, b) = (draw(), draw());
    assert_eq!(&a[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(a, b);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| Focus::compute(&scene, 0).unwrap());
    assert_eq!(single, focus);
}

#[test]
fn bad_requests_are_errors_not_panics() {
    let scene = street();
    let err = crate::common::error_of(Focus::compute(&scene, 2), citypvs::ErrorKind::Usage);
    assert!(err.contains("cell 2"), "{err}");
    let err = crate::common::error_of(Focus::new(&scene, 0, vec![7]), citypvs::ErrorKind::Usage);
    assert!(err.contains("object 7"), "{err}");
    let sizes = [1usize];
    assert!(
        render(&Picture {
            pvs_sizes: Some(&sizes),
            ..picture(&scene)
        })
        .is_err()
    );
    assert!(
        render(&Picture {
            width: 10,
            ..picture(&scene)
        })
        .is_err()
    );
    let empty = hand_scene(vec![], vec![], 1.0);
    assert!(render(&picture(&empty)).is_err());
    let degenerate = Rect {
        min: DVec2::ZERO,
        max: DVec2::ZERO,
    };
    assert!(
        render(&Picture {
            view: Some(degenerate),
            ..picture(&scene)
        })
        .is_err()
    );
}

#[test]
fn points_find_their_cell() {
    let scene = street();
    assert_eq!(cell_containing(&scene, DVec2::new(0.0, 0.0)), Some(0));
    assert_eq!(cell_containing(&scene, DVec2::new(55.0, 22.0)), Some(1));
    assert_eq!(cell_containing(&scene, DVec2::new(0.0, 22.0)), None);
}
