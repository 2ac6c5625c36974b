//! Reading a large generated city, for measuring (run with `--ignored
//! --nocapture`): prints the time and the size; asserts only the count.

use std::time::Instant;

use citypvs::generate::{GenerateParams, generate_geojson};
use citypvs::input::{InputOptions, read_city_bytes};

#[test]
#[ignore = "measurement: about 2 s and 0.5 GB"]
fn read_100k_generated_buildings() {
    let params = GenerateParams {
        buildings: 100_000,
        seed: 1,
    };
    let text = generate_geojson(&params);
    let start = Instant::now();
    let city = read_city_bytes(text.as_bytes(), "generated", &InputOptions::default()).unwrap();
    let elapsed = start.elapsed();
    assert_eq!(city.buildings.len(), 100_000);
    let vertices: usize = city
        .buildings
        .iter()
        .flat_map(|b| &b.footprint)
        .map(|p| p.exterior.len() + p.holes.iter().map(Vec::len).sum::<usize>())
        .sum();
    println!(
        "read {} buildings ({vertices} vertices, {:.1} MB of GeoJSON) in {:.3} s",
        city.buildings.len(),
        text.len() as f64 / 1e6,
        elapsed.as_secs_f64()
    );
}
