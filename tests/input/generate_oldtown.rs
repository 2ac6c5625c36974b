//! The old-town style of `generate`: deterministic, exactly N buildings,
//! and shared walls drawn with gaps, overlaps and one-sided vertices.

use citypvs::generate::{GenerateParams, Style, generate_geojson_styled, generate_styled};
use citypvs::model::Rect;

fn params(buildings: usize, seed: u64) -> GenerateParams {
    GenerateParams { buildings, seed }
}

#[test]
fn same_seed_same_bytes_other_seed_other_city() {
    let a = generate_geojson_styled(&params(700, 4), Style::OldTown);
    let b = generate_geojson_styled(&params(700, 4), Style::OldTown);
    let c = generate_geojson_styled(&params(700, 5), Style::OldTown);
    assert_eq!(a, b);
    assert_ne!(a, c);
    // Nine decimals: millimetre misalignments survive the lon/lat text.
    assert!(a.contains("[24.93"), "{}", &a[..200]);
    let first = a.split("[[[").nth(1).unwrap();
    let lon = first.split(',').next().unwrap();
    assert_eq!(lon.split('.').nth(1).unwrap().len(), 9, "{lon}");
    // The default style is untouched by the option.
    let d = generate_geojson_styled(&params(700, 4), Style::Default);
    assert_eq!(d, citypvs::generate::generate_geojson(&params(700, 4)));
}

#[test]
fn shared_walls_are_drawn_like_real_map_data() {
    let city = generate_styled(&params(2000, 1), Style::OldTown);
    assert_eq!(city.buildings.len(), 2000);
    let footprints: Vec<geo::MultiPolygon<f64>> = city
        .buildings
        .iter()
        .map(|b| {
            citypvs::geometry::convert::multipolygon_to_geo(std::slice::from_ref(&b.footprint))
        })
        .collect();
    let boxes: Vec<Rect> = city
        .buildings
        .iter()
        .map(|b| citypvs::model::multipolygon_bounds(std::slice::from_ref(&b.footprint)))
        .collect();
    use geo::{Area, BooleanOps, Distance, Euclidean};
    let (mut overlaps, mut gaps, mut exact, mut narrow_gaps) = (0, 0, 0, 0);
    for i in 0..footprints.len() {
        for j in i + 1..footprints.len() {
            if !boxes[i].grown(0.5).intersects(&boxes[j]) {
                continue;
            }
            let inter = footprints[i].intersection(&footprints[j]).unsigned_area();
            let d = Euclidean.distance(&footprints[i], &footprints[j]);
            if inter > 1e-6 {
                overlaps += 1;
            } else if d == 0.0 {
                exact += 1;
            } else if d < 0.2 {
                gaps += 1;
            } else if d < 0.5 {
                narrow_gaps += 1;
            }
        }
    }
    assert!(overlaps > 100, "{overlaps} overlapping neighbours");
    assert!(gaps > 100, "{gaps} neighbours with small gaps");
    assert!(exact > 50, "{exact} exactly shared walls");
    assert!(
        narrow_gaps > 5,
        "{narrow_gaps} passages narrower than half a metre"
    );
    let wells = city
        .buildings
        .iter()
        .filter(|b| !b.footprint.holes.is_empty())
        .count();
    assert!(wells > 20, "{wells} light wells");
}
