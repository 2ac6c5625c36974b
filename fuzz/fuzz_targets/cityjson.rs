//! Fuzz target: the CityJSON reader, through the library's read-from-bytes
//! entry. Any input must give a city or an error, never a panic, an abort or
//! a hang.
#![no_main]

use citypvs::input::{Format, InputOptions, read_city_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let options = InputOptions {
        format: Some(Format::Cityjson),
        ..InputOptions::default()
    };
    let _ = read_city_bytes(data, "fuzz.city.json", &options);
});
