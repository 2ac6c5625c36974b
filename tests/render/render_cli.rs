//! The `render` command's flow after preparation: a `.pvs` file
//! baked from a hand scene is opened and checked, cells are chosen by index
//! or by point, and the layers come from the file.

use std::path::Path;

use crate::common::*;
use citypvs::bake::bake;
use citypvs::cli::render::{RenderArgs, draw};
use citypvs::cli::{Cli, Command};
use citypvs::prepare::Scene;
use citypvs::pvs::{PvsReader, write_pvs};
use citypvs::render::palette;
use citypvs::visibility::VisibilityEngine;
use clap::Parser;
use glam::DVec2;

fn street(eps: f64) -> Scene {
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
        eps,
    )
}

fn baked(scene: &Scene, path: &Path) {
    let (data, _, _) = bake(scene, &|_| {}).unwrap();
    write_pvs(path, &data).unwrap();
}

fn args(extra: &[&str]) -> RenderArgs {
    let mut argv = vec![
        "citypvs",
        "render",
        "street.geojson",
        "-o",
        "street.png",
        "--metric",
    ];
    argv.extend_from_slice(extra);
    match Cli::try_parse_from(argv).unwrap().command {
        Command::Render(a) => a,
        other => panic!("parsed as {other:?}"),
    }
}

#[test]
fn cell_from_a_pvs_file_chosen_by_point() {
    let dir = tempfile::tempdir().unwrap();
    let pvs = dir.path().join("street.pvs");
    let scene = street(1.0);
    baked(&scene, &pvs);
    let pvs = pvs.to_str().unwrap();
    let reader = PvsReader::open(Path::new(pvs)).unwrap();
    let drawing = draw(
        &args(&["--pvs", pvs, "--at=0.5,-0.5", "--size", "400"]),
        &scene,
        Some(&reader),
    )
    .unwrap();
    let focus = drawing.focus.expect("a chosen cell");
    assert_eq!(focus.cell, 0);
    let expected = VisibilityEngine::new(&scene).unwrap().solve_cell(0);
    assert_eq!(focus.visible, expected);
    let r = &drawing.rendered;
    assert_eq!(r.pixmap.width(), 400);
    assert_eq!(r.colour_at(DVec2::new(0.0, 35.0)), Some(palette::CULLED));
    assert_eq!(r.colour_at(DVec2::new(0.0, 12.0)), Some(palette::VISIBLE));
    assert_eq!(
        r.colour_at(DVec2::new(0.0, 0.0)),
        Some(palette::CHOSEN_CELL)
    );
}

#[test]
fn pvs_size_layer_reads_every_cell_from_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let pvs = dir.path().join("street.pvs");
    let scene = street(1.0);
    baked(&scene, &pvs);
    let a = args(&[
        "--pvs",
        pvs.to_str().unwrap(),
        "--layer",
        "pvs-size",
        "--size",
        "400",
    ]);
    let reader = PvsReader::open(&pvs).unwrap();
    let drawing = draw(&a, &scene, Some(&reader)).unwrap();
    assert!(drawing.focus.is_none());
    let sizes: Vec<usize> = VisibilityEngine::new(&scene)
        .unwrap()
        .solve_all(&|_| {})
        .unwrap()
        .iter()
        .map(Vec::len)
        .collect();
    let (lo, hi) = (sizes[0].min(sizes[1]), sizes[0].max(sizes[1]));
    assert!(lo < hi);
    for (c, centre) in [DVec2::new(0.0, -1.0), DVec2::new(55.0, 21.0)]
        .into_iter()
        .enumerate()
    {
        let t = (sizes[c] - lo) as f64 / (hi - lo) as f64;
        assert_eq!(
            drawing.rendered.colour_at(centre),
            Some(palette::PVS_RAMP.step(t))
        );
    }
}

#[test]
fn cull_map_and_radius_zoom_around_the_cell_without_a_file() {
    let scene = street(1.0);
    let a = args(&[
        "--cell", "0", "--layer", "cullmap", "--radius", "30", "--size", "300",
    ]);
    let drawing = draw(&a, &scene, None).unwrap();
    let r = &drawing.rendered;
    assert!((r.viewport.scale - 300.0 / 60.0).abs() < 1e-9);
    // Behind the wall the heat is on, in front of it there is none.
    let behind = r.colour_at(DVec2::new(-20.0, 22.0)).unwrap();
    assert!(
        palette::CULL_RAMP
            .0
            .iter()
            .any(|_| behind != palette::OUTSIDE)
    );
    assert_eq!(behind, palette::CULL_RAMP.step(1.0));
    assert_eq!(r.colour_at(DVec2::new(-20.0, -8.0)), Some(palette::OUTSIDE));
    assert!(
        r.colour_at(DVec2::new(0.0, 35.0)).is_none(),
        "the house is beyond 30 m"
    );
}

#[test]
fn mismatched_files_and_bad_choices_are_explained() {
    let dir = tempfile::tempdir().unwrap();
    let pvs = dir.path().join("street.pvs");
    baked(&street(1.0), &pvs);
    let pvs = pvs.to_str().unwrap();
    let other_eps = street(2.0);
    let reader = PvsReader::open(Path::new(pvs)).unwrap();
    let e = draw(
        &args(&["--pvs", pvs, "--cell", "0"]),
        &other_eps,
        Some(&reader),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("baked with eps 1"), "{e}");
    let scene = street(1.0);
    let e = draw(&args(&["--at=0,22"]), &scene, None)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("in no view cell"), "{e}");
    let e = draw(&args(&["--cell", "5"]), &scene, None)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("--cell 5"), "{e}");
    let e = draw(&args(&["--layer", "cullmap"]), &scene, None)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("--cell N or --at"), "{e}");
    let e = draw(&args(&["--cell", "0", "--radius=-3"]), &scene, None)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("--radius"), "{e}");
    assert!(
        Cli::try_parse_from([
            "citypvs",
            "render",
            "c.geojson",
            "-o",
            "x.png",
            "--cell",
            "1",
            "--at=1,2"
        ])
        .is_err()
    );
}
