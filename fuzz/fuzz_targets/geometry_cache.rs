//! Fuzz target: the geometry cache reader (`citypvs::scale::geometry_cache`,
//! docs/scale-out.md). A cache that reads must hold only rings of at least
//! three finite points, and must write and read back to the same shapes;
//! anything else must be an error, never a panic, an abort or a hang.
//!
//! The input is a cache's **payload** (the file without its 56-byte
//! preamble). It is fed twice: as a whole file as it is, and sealed (the
//! preamble with the right magic, version, length and SHA-256 put in
//! front), so that mutations reach the payload's decoding and checks. The
//! seeds in `corpus/geometry_cache` are payloads of caches of small cities
//! made by this build (a payload of another build is refused as such).
#![no_main]


use citypvs::geometry::memo::ShapeMemo;
use citypvs::scale::geometry_cache::{CACHE_MAGIC, CACHE_VERSION, decode, encode};
use libfuzzer_sys::fuzz_target;

fn exercise(bytes: &[u8]) {
    let Ok(shapes) = decode(bytes) else {
        return;
    };
    for shape in shapes.values() {
        for p in shape {
            for ring in std::iter::once(&p.exterior).chain(&p.holes) {
                assert!(ring.len() >= 3, "a ring of {} points", ring.len());
                assert!(
                    ring.iter().all(|v| v.is_finite()),
                    "a coordinate not finite"
                );
            }
        }
    }
    // Taken whole by a run and written back, the shapes read the same.
    let keys: Vec<_> = shapes.keys().copied().collect();
    let memo = ShapeMemo::with(shapes.clone());
    for key in &keys {
        memo.shape(|| *key, || unreachable!("every key is held"));
    }
    let again = decode(&encode(&memo.into_results())).expect("a written cache reads");
    assert!(again == shapes, "the shapes changed on the way");
}

fuzz_target!(|payload: &[u8]| {
    exercise(payload);
    exercise(&citypvs::scale::sealed::seal(&CACHE_MAGIC, CACHE_VERSION, payload));
});
