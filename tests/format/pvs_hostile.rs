//! Hostile `.pvs` files: the reader never panics, never reads out of bounds
//! and never allocates more than a small multiple of the file's size,
//! whatever the bytes. Mutated and truncated real baked files get their
//! length field and checksum recomputed so the mutations reach the parser.
//! A counting global allocator (this binary only) measures the peak bytes
//! held by the thread that opens and decodes.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::process::Command;
use std::sync::OnceLock;

use citypvs::pvs::{BakeInfo, PvsReader, PvsWriter};
use glam::DVec2;
use proptest::prelude::*;
use sha2::{Digest, Sha256};

struct Counting;

thread_local! {
    static HELD: Cell<usize> = const { Cell::new(0) };
    static PEAK: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = HELD.try_with(|h| {
            let now = h.get() + layout.size();
            h.set(now);
            let _ = PEAK.try_with(|p| p.set(p.get().max(now)));
        });
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let _ = HELD.try_with(|h| h.set(h.get().saturating_sub(layout.size())));
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Peak bytes allocated (beyond those held at the start) while `f` runs on this thread.
fn peak_during<T>(f: impl FnOnce() -> T) -> (T, usize) {
    let base = HELD.with(Cell::get);
    PEAK.with(|p| p.set(base));
    let out = f();
    (out, PEAK.with(Cell::get) - base)
}

/// The documented cap (docs/FORMAT.md, "Hostile files"): 64 x the file's
/// size plus 64 KiB.
fn cap(file: usize) -> usize {
    64 * file + 64 * 1024
}

/// Open, then decode every cell both ways and look up points; return whether it opened.
fn exercise(bytes: Vec<u8>) -> bool {
    let Ok(r) = PvsReader::from_bytes(bytes) else {
        return false;
    };
    let n = r.object_ids().len() as u32;
    for c in 0..r.cell_count().min(300) {
        if let Ok(set) = r.visible(c) {
            assert!(set.windows(2).all(|w| w[0] < w[1]));
            assert!(set.iter().all(|&i| i < n));
        }
        let t = r.cell_triangle(c);
        let _ = r.cell_at(t[0]);
        let _ = r.cell_at((t[0] + t[1] + t[2]) / 3.0);
    }
    let _ = r.for_each_visible(|_, set| {
        assert!(set.iter().all(|&i| i < n));
        Ok(())
    });
    let _ = r.cell_at(DVec2::new(1e300, -1e300));
    true
}

/// Set the length field and the checksum so the parser sees the bytes.
fn reseal(mut bytes: Vec<u8>) -> Vec<u8> {
    if bytes.len() < 56 {
        return bytes;
    }
    let len = bytes.len() as u64;
    bytes[16..24].copy_from_slice(&len.to_le_bytes());
    let body = bytes.len() - 32;
    let digest = Sha256::digest(&bytes[..body]);
    bytes[body..].copy_from_slice(&digest);
    bytes
}

/// Two real baked files: a small generated city, baked by the CLI.
fn baked() -> &'static [Vec<u8>] {
    static FILES: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let bin = env!("CARGO_BIN_EXE_citypvs");
        [(25, 4), (60, 9)]
            .iter()
            .map(|(buildings, seed)| {
                let city = dir.path().join(format!("c{seed}.geojson"));
                let pvs = dir.path().join(format!("c{seed}.pvs"));
                let ok = |c: &mut Command| assert!(c.status().unwrap().success());
                ok(Command::new(bin)
                    .args([
                        "generate",
                        "--buildings",
                        &buildings.to_string(),
                        "--seed",
                        &seed.to_string(),
                        "-o",
                    ])
                    .arg(&city));
                ok(Command::new(bin)
                    .arg("bake")
                    .arg(&city)
                    .arg("-o")
                    .arg(&pvs)
                    .args(["-q", "--threads", "1"]));
                std::fs::read(&pvs).unwrap()
            })
            .collect()
    })
}

#[derive(Clone, Debug)]
enum Mutation {
    /// Overwrite one byte.
    Byte(usize, u8),
    /// Overwrite 4 or 8 bytes with a little-endian number (sizes, counts).
    Word(usize, u64, bool),
    /// Cut the file to this fraction, keeping room for a checksum.
    Truncate(usize),
    /// Insert bytes.
    Insert(usize, Vec<u8>),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let big = prop_oneof![
        Just(0u64),
        Just(1),
        Just(u64::from(u32::MAX)),
        Just(u64::MAX),
        Just(1 << 31),
        0u64..100_000,
        any::<u64>()
    ];
    prop_oneof![
        4 => (any::<usize>(), any::<u8>()).prop_map(|(a, b)| Mutation::Byte(a, b)),
        3 => (any::<usize>(), big, any::<bool>()).prop_map(|(a, v, w)| Mutation::Word(a, v, w)),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        1 => (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(a, v)| Mutation::Insert(a, v)),
    ]
}

fn apply(mut bytes: Vec<u8>, m: &Mutation) -> Vec<u8> {
    // Target the header and the first sections more often: that is where the sizes live.
    let pick = |a: usize, len: usize| {
        if a.is_multiple_of(3) {
            a / 3 % len.min(400)
        } else {
            a / 3 % len
        }
    };
    let body = bytes.len() - 32;
    match m {
        Mutation::Byte(a, b) => {
            let at = pick(*a, body);
            bytes[at] = *b;
        }
        Mutation::Word(a, v, wide) => {
            let w = if *wide { 8 } else { 4 };
            let at = pick(*a, body - w);
            bytes[at..at + w].copy_from_slice(&v.to_le_bytes()[..w]);
        }
        Mutation::Truncate(a) => {
            // An earlier truncation may already have cut the file to 56
            // bytes: then there is nothing shorter to keep.
            let keep = 56 + a % (body - 24).max(1);
            bytes.truncate(keep);
        }
        Mutation::Insert(a, v) => {
            let at = pick(*a, body);
            bytes.splice(at..at, v.iter().copied());
        }
    }
    bytes
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    #[test]
    fn mutated_baked_files_never_panic_or_overallocate(
        which in 0usize..2,
        mutations in proptest::collection::vec(mutation(), 1..4),
    ) {
        let mut bytes = baked()[which].clone();
        for m in &mutations {
            bytes = apply(bytes, m);
        }
        let bytes = reseal(bytes);
        let len = bytes.len();
        let (_, peak) = peak_during(|| exercise(bytes));
        prop_assert!(peak <= cap(len), "peak {peak} bytes for a {len}-byte file");
    }
}

#[test]
fn baked_files_open_within_the_cap() {
    for bytes in baked() {
        let len = bytes.len();
        let (opened, peak) = peak_during(|| exercise(bytes.clone()));
        assert!(opened);
        assert!(peak <= cap(len), "peak {peak} for {len}");
    }
}

fn info() -> BakeInfo {
    BakeInfo {
        numbers: citypvs::BakeNumbers {
            eps: 1.0,
            eye_height: 1.7,
            pixel: 1.0,
            max_cell_edge: 30.0,
            margin: 50.0,
            near_field: 64.0,
            min_gap: 0.0,
        },
        frame: citypvs::frame::Frame::Metric {
            origin: DVec2::ZERO,
            crs: None,
        },
        source_hash: [1; 32],
        region_hash: [0; 32],
        tool_version: "test".into(),
    }
}

/// The version 1 layout's overflow: a 212-byte file whose header claims
/// 2^32 - 1 objects. Version 2 readers refuse version 1 by its number; the
/// converter's version 1 parser bounds every string by the body, so the
/// count check cannot wrap.
#[test]
fn crafted_212_byte_version_1_file() {
    let mut b = Vec::new();
    b.extend_from_slice(b"CITYPVS\0");
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(&212u64.to_le_bytes());
    for v in [1.0f64, 1.7, 1.0, 30.0, 50.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&1u32.to_le_bytes()); // metric
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(&[0; 16]); // origin
    b.extend_from_slice(&[0; 32]); // source hash
    b.extend_from_slice(&u32::MAX.to_le_bytes()); // objects
    b.extend_from_slice(&u32::MAX.to_le_bytes()); // cells
    for v in [180u64, 180, 180, 180, 0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(b.len(), 168);
    b.extend_from_slice(&8u32.to_le_bytes());
    b.extend_from_slice(b"citypvs!");
    let digest = Sha256::digest(&b);
    b.extend_from_slice(&digest);
    assert_eq!(b.len(), 212);
    let (err, peak) = peak_during(|| PvsReader::from_bytes(b.clone()).err().unwrap());
    assert!(err.message().contains("version 1 file: rebake"), "{err}");
    assert!(peak < 4096);
    let (res, peak) = peak_during(|| citypvs::pvs::v1::read_v1(&b));
    assert!(res.is_err());
    assert!(peak < 4096, "{peak}");
}

/// The same in version 2: counts far beyond what their sections can hold
/// are refused before anything is allocated.
#[test]
fn crafted_version_2_counts_are_refused() {
    let mut w = PvsWriter::new(
        info(),
        vec!["a".into()],
        vec![DVec2::ZERO],
        vec![[DVec2::ZERO, DVec2::X, DVec2::Y]],
    )
    .unwrap();
    w.push_cell(&[0]).unwrap();
    let good = w.finish().unwrap().0;
    assert!(PvsReader::from_bytes(good.clone()).is_ok());
    for (at, what) in [(168, "objects"), (172, "cells"), (176, "vertices")] {
        let mut b = good.clone();
        b[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let b = reseal(b);
        let len = b.len();
        let (err, peak) = peak_during(|| PvsReader::from_bytes(b).err().expect(what));
        assert!(peak <= cap(len), "{what}: {peak}");
        assert!(!err.message().is_empty());
    }
    // A section length pointing past the checksum.
    let mut b = good.clone();
    b[184 + 8..184 + 16].copy_from_slice(&u64::MAX.to_le_bytes());
    let err = PvsReader::from_bytes(reseal(b)).err().unwrap();
    assert!(err.message().contains("objects section"), "{err}");
}

/// Every cell's run expands to every object: the file is small, the sets
/// are huge; inspect streams, so it never holds cells x objects.
#[test]
fn inspect_streams_sets_that_expand_to_every_object() {
    let (objects, cells) = (20_000usize, 20_000usize);
    let ids: Vec<String> = (0..objects).map(|i| i.to_string()).collect();
    let points: Vec<DVec2> = (0..objects).map(|i| DVec2::new(i as f64, 0.0)).collect();
    let tris: Vec<[DVec2; 3]> = (0..cells)
        .map(|c| {
            let x = c as f64;
            [
                DVec2::new(x, 0.0),
                DVec2::new(x + 1.0, 0.0),
                DVec2::new(x, 1.0),
            ]
        })
        .collect();
    let mut w = PvsWriter::new(info(), ids, points, tris).unwrap();
    let all: Vec<u32> = (0..objects as u32).collect();
    for _ in 0..cells {
        w.push_cell(&all).unwrap();
    }
    let bytes = w.finish().unwrap().0;
    let held = cells * objects * 4;
    assert!(
        bytes.len() * 100 < held,
        "the file ({}) is much smaller than the sets ({held})",
        bytes.len()
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("all.pvs");
    std::fs::write(&path, &bytes).unwrap();
    let args = citypvs::cli::inspect::InspectArgs {
        file: path,
        cell: None,
        json: false,
    };
    let (code, peak) = peak_during(|| citypvs::cli::inspect::run(&args).unwrap());
    assert_eq!(code, 0);
    assert!(
        peak <= cap(bytes.len()) + 4 * objects * 70,
        "inspect peak {peak}"
    );
    assert!(peak < held / 100);
}

#[test]
fn text_inspect_escapes_control_characters() {
    let e = citypvs::cli::inspect::escape_controls("way/1\u{1b}[31mred\n");
    assert_eq!(e, "way/1\\u{1b}[31mred\\n");
    assert_eq!(citypvs::cli::inspect::escape_controls("plain/ä"), "plain/ä");
}

/// The input the version 1 fuzz run saved (a header whose object table
/// offset lies past the end of the body; once an unsigned subtraction that
/// wrapped), sealed with a right length and checksum: the version 2 reader
/// refuses it as version 1 and the converter's version 1 parser gives an
/// error, both without panicking.
#[test]
fn saved_version_1_fuzz_input_is_refused() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fuzz/crashes/pvs/subtract-overflow-read-rs-248.body"
    );
    let mut b = std::fs::read(path).unwrap();
    assert_eq!(&b[8..12], &1u32.to_le_bytes());
    let len = (b.len() + 32) as u64;
    b[16..24].copy_from_slice(&len.to_le_bytes());
    let digest = Sha256::digest(&b);
    b.extend_from_slice(&digest);
    let err = PvsReader::from_bytes(b.clone()).err().unwrap();
    assert!(err.message().contains("version 1 file: rebake"), "{err}");
    let (res, peak) = peak_during(|| citypvs::pvs::v1::read_v1(&b));
    let err = res.err().unwrap();
    assert!(!err.message().is_empty());
    assert!(peak <= cap(b.len()), "{peak}");
}
