//! Fuzz target: the .pvs reader. A file that opens must answer `visible`
//! (and `visible_ids`) for every cell with a set or an error, never a
//! panic, an abort or a hang.
#![no_main]

use citypvs::pvs::PvsReader;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(reader) = PvsReader::from_bytes(data.to_vec()) else {
        return;
    };
    for cell in 0..reader.cell_count() {
        let _ = reader.visible(cell);
        let _ = reader.visible_ids(cell);
    }
});
