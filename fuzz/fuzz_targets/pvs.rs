//! Fuzz target: the .pvs reader. A file that opens must answer `visible`
//! (and `visible_ids`) for every cell with a set or an error, never a
//! panic, an abort or a hang.
//!
//! The input is fed twice: as it is, and as a file body whose length field
//! (bytes 16..24) and SHA-256 checksum (appended) are made right, so that
//! mutations get past the checksum and reach the tables and records. The
//! seeds in `corpus/pvs` are therefore files without their last 32 bytes.
#![no_main]

use citypvs::pvs::PvsReader;
use libfuzzer_sys::fuzz_target;
use sha2::{Digest, Sha256};

fn exercise(bytes: Vec<u8>) {
    let Ok(reader) = PvsReader::from_bytes(bytes) else {
        return;
    };
    for cell in 0..reader.cell_count() {
        let _ = reader.visible(cell);
        let _ = reader.visible_ids(cell);
    }
}

fuzz_target!(|data: &[u8]| {
    exercise(data.to_vec());
    if data.len() >= 24 {
        let mut file = data.to_vec();
        let total = (data.len() + 32) as u64;
        file[16..24].copy_from_slice(&total.to_le_bytes());
        let digest = Sha256::digest(&file);
        file.extend_from_slice(&digest);
        exercise(file);
    }
});
