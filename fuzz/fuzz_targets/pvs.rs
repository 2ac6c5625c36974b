//! Fuzz target: the .pvs reader (format version 3, docs/FORMAT.md). A file
//! that opens must answer `visible`, `visible_ids`, `for_each_visible` and
//! `cell_at` with a result or an error, never a panic, an abort or a hang.
//!
//! The input is a file **body** (a file without its last 32 bytes, the
//! checksum) and is fed three ways so that mutations reach the section
//! parsers and the block decoder:
//!
//! 1. as it is, as a whole file (the magic, version, length and checksum
//!    checks);
//! 2. sealed: `file_bytes` (bytes 16..24) set to the body's length + 32 and
//!    the SHA-256 of the body appended;
//! 3. sealed after also making the sections end at the checksum: the last
//!    section length (`len_blocks`, bytes 224..232) absorbs whatever the
//!    other five leave, and the block index's last offset is set to it, so
//!    bytes inserted into or cut from a block still reach the decoder.
//!
//! A body whose version field is 1 also goes, sealed, to the version 1
//! parser kept for conversions (`citypvs::pvs::v1::read_v1`).
//!
//! The seeds in `corpus/pvs` are therefore real bakes without their last 32
//! bytes.
#![no_main]

use citypvs::pvs::PvsReader;
use glam::DVec2;
use libfuzzer_sys::fuzz_target;
use sha2::{Digest, Sha256};

const HEADER: usize = 232;

fn exercise(bytes: Vec<u8>) {
    let Ok(reader) = PvsReader::from_bytes(bytes) else {
        return;
    };
    let n = reader.object_ids().len() as u32;
    let cells = reader.cell_count();
    for cell in 0..cells.min(512) {
        if let Ok(set) = reader.visible(cell) {
            assert!(set.windows(2).all(|w| w[0] < w[1]), "set not ascending");
            assert!(set.iter().all(|&i| i < n), "object index out of range");
        }
        let _ = reader.visible_ids(cell);
    }
    // Past the end: an error, not a panic.
    let _ = reader.visible(cells);
    let _ = reader.visible_ids(usize::MAX);
    let mut seen = 0usize;
    let _ = reader.for_each_visible(|cell, set| {
        assert_eq!(cell, seen, "cells out of order");
        seen += 1;
        assert!(set.iter().all(|&i| i < n), "object index out of range");
        Ok(())
    });
    for cell in (0..cells).step_by(cells.div_ceil(16).max(1)) {
        let t = reader.cell_triangle(cell);
        for p in [t[0], (t[0] + t[1]) * 0.5, (t[0] + t[1] + t[2]) / 3.0] {
            if let Some(c) = reader.cell_at(p) {
                assert!(c < cells, "cell_at gave a cell past the end");
            }
        }
    }
    for p in [
        DVec2::ZERO,
        DVec2::new(1e300, -1e300),
        DVec2::new(f64::NAN, 0.0),
        DVec2::new(f64::INFINITY, f64::NEG_INFINITY),
        DVec2::new(-0.0, 5e-324),
    ] {
        let _ = reader.cell_at(p);
    }
}

/// The body with its length field and checksum made right.
fn seal(body: &[u8]) -> Vec<u8> {
    let mut file = body.to_vec();
    let total = (body.len() + 32) as u64;
    file[16..24].copy_from_slice(&total.to_le_bytes());
    let digest = Sha256::digest(&file);
    file.extend_from_slice(&digest);
    file
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// The body with `len_blocks` and the last block offset set so that the
/// sections end at the checksum; `None` if it cannot be done or changes
/// nothing.
fn fit_sections(body: &[u8]) -> Option<Vec<u8>> {
    if body.len() < HEADER {
        return None;
    }
    let first5 = (0..5).try_fold(0u64, |s, k| s.checked_add(u64_at(body, 184 + 8 * k)))?;
    let len_blocks = (body.len() as u64)
        .checked_sub(HEADER as u64)?
        .checked_sub(first5)?;
    let mut out = body.to_vec();
    out[224..232].copy_from_slice(&len_blocks.to_le_bytes());
    let index_end = HEADER as u64 + first5;
    let len_index = u64_at(body, 216);
    if len_index >= 8 {
        let last = usize::try_from(index_end - 8).ok()?;
        out[last..last + 8].copy_from_slice(&len_blocks.to_le_bytes());
    }
    (out != body).then_some(out)
}

fuzz_target!(|data: &[u8]| {
    exercise(data.to_vec());
    if data.len() < 24 {
        return;
    }
    let sealed = seal(data);
    if data.len() >= 12 && data[8..12] == 1u32.to_le_bytes() {
        let _ = citypvs::pvs::v1::read_v1(&sealed);
        return;
    }
    exercise(sealed);
    if let Some(fitted) = fit_sections(data) {
        exercise(seal(&fitted));
    }
});
