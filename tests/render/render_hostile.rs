//! `render` refuses, before the work, cull maps and cull-map grids too
//! large to make: an absurd `--radius`, and a `.pvs` whose header holds a
//! tiny, zero or negative pixel size.

use crate::common::{citypvs, stderr};
use std::path::Path;
use std::process::Output;
use std::time::Instant;

const CITY: &str = r#"{"type":"FeatureCollection","features":[
{"type":"Feature","properties":{"id":"a","height":10},"geometry":{"type":"Polygon","coordinates":[[[0,0],[20,0],[20,20],[0,20],[0,0]]]}},
{"type":"Feature","properties":{"id":"b","height":12},"geometry":{"type":"Polygon","coordinates":[[[40,0],[60,0],[60,20],[40,20],[40,0]]]}}
]}"#;

fn city_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("city.geojson"), CITY).unwrap();
    dir
}

fn render(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        "city.geojson",
        "--metric",
        "--cell",
        "0",
        "-o",
        "out.png",
    ];
    args.extend_from_slice(extra);
    citypvs(dir, &args)
}

#[test]
fn an_absurd_radius_is_refused_with_the_cull_map_size_and_the_largest_radius() {
    let dir = city_dir();
    for radius in ["1e9", "20000"] {
        let t = Instant::now();
        let out = render(dir.path(), &["--layer", "cullmap", "--radius", radius]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "--radius {radius}: {}",
            stderr(&out)
        );
        let e = stderr(&out);
        assert!(
            e.contains(&format!("--radius {radius}").replace("1e9", "1000000000")),
            "{e}"
        );
        assert!(e.contains("pixels") && e.contains("give --radius"), "{e}");
        assert!(
            t.elapsed().as_secs() < 20,
            "--radius {radius} took {:?}",
            t.elapsed()
        );
        assert!(!dir.path().join("out.png").exists());
    }
}

#[test]
fn the_largest_radius_the_message_offers_is_accepted() {
    let dir = city_dir();
    let out = render(dir.path(), &["--layer", "cullmap", "--radius", "1e9"]);
    let e = stderr(&out);
    let offered: String = e
        .rsplit("give --radius ")
        .next()
        .unwrap()
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    let offered: f64 = offered.parse().unwrap();
    assert!(offered > 1000.0, "{e}");
    // The offer draws; a little over it is refused.
    let out = render(
        dir.path(),
        &["--layer", "cullmap", "--radius", &offered.to_string()],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let over = format!("{}", offered + 50.0);
    let out = render(dir.path(), &["--layer", "cullmap", "--radius", &over]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
}

/// Bake the city, then rewrite the file with another pixel size in its header.
fn pvs_with_pixel(dir: &Path, pixel: f64) -> String {
    let out = citypvs(
        dir,
        &["bake", "city.geojson", "--metric", "-q", "-o", "good.pvs"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let good = std::fs::read(dir.join("good.pvs")).unwrap();
    let name = format!("pixel-{pixel}.pvs");
    std::fs::write(
        dir.join(&name),
        crate::common::with_header_number(good, crate::common::HEADER_PIXEL, pixel),
    )
    .unwrap();
    name
}

#[test]
fn a_pvs_header_with_a_tiny_zero_or_negative_pixel_is_refused_before_the_work() {
    let dir = city_dir();
    for pixel in [1e-7, 0.0, -0.5, -1e-9] {
        let name = pvs_with_pixel(dir.path(), pixel);
        let t = Instant::now();
        let out = render(dir.path(), &["--pvs", &name, "--layer", "cullmap"]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "pixel {pixel}: {}",
            stderr(&out)
        );
        let e = stderr(&out);
        assert!(e.contains(&name) && e.contains("pixel"), "{e}");
        assert!(
            t.elapsed().as_secs() < 20,
            "pixel {pixel} took {:?}",
            t.elapsed()
        );
    }
}
