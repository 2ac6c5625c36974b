//! Fuzz target: the GeoJSON reader (lon/lat and metric), through the
//! library's read-from-bytes entry. Any input must give a city or an error,
//! never a panic, an abort or a hang.
#![no_main]

use citypvs::input::{Format, InputOptions, read_city_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte picks lon/lat or metres and --strict.
    let Some((&flags, bytes)) = data.split_first() else {
        return;
    };
    let options = InputOptions {
        metric: flags & 1 != 0,
        strict: flags & 2 != 0,
        format: Some(Format::Geojson),
        ..InputOptions::default()
    };
    let _ = read_city_bytes(bytes, "fuzz.geojson", &options);
});
