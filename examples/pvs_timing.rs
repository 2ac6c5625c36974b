//! Time the reader on a baked file (docs/FORMAT.md, "Measurements"): open
//! (checksum, tables, point grid), decode every cell's set, and decode one
//! cell (the mean over 2,000 cells spread over the file, each from a fresh
//! start of its block). Prints the section sizes too.
//!
//! cargo run --release --example pvs_timing -- CITY.pvs

use std::time::Instant;

use citypvs::pvs::PvsReader;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: pvs_timing FILE.pvs");
        std::process::exit(2);
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    };
    let t = Instant::now();
    let reader = match PvsReader::from_bytes(bytes) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    };
    let open = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut visible = 0usize;
    reader
        .for_each_visible(|_, set| {
            visible += set.len();
            Ok(())
        })
        .expect("a file that opens decodes");
    let all = t.elapsed().as_secs_f64();
    let cells = reader.cell_count();
    let picks: Vec<usize> = (0..2000).map(|k| (k * 7919) % cells.max(1)).collect();
    let t = Instant::now();
    for &c in &picks {
        reader.visible(c).expect("a file that opens decodes");
    }
    let one = t.elapsed().as_secs_f64() / picks.len() as f64;
    println!(
        "{path}: {} bytes, {cells} cells ({} per block), {} objects, {} vertices, blocks {} bytes, mean visible {:.2}",
        reader.file_bytes(),
        reader.block_cells(),
        reader.object_ids().len(),
        reader.vertex_count(),
        reader.block_bytes(),
        visible as f64 / cells.max(1) as f64
    );
    println!(
        "open {:.1} ms, every cell {:.3} s, one cell {:.3} ms",
        open * 1e3,
        all,
        one * 1e3
    );
}
