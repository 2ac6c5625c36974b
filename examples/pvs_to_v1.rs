//! Measurement helper: read a `.pvs` file with this citypvs's reader and
//! write the same data in the old version 1 layout (`citypvs::pvs::v1`), so
//! that `tests/format/pvs_v2_measure.rs` can re-encode the sets and the
//! version 1 size and general-purpose compressors of it can be measured.
//!
//!     cargo run --release --example pvs_to_v1 -- in.pvs out.v1.pvs

use citypvs::pvs::PvsReader;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: pvs_to_v1 IN.pvs OUT.v1.pvs");
        std::process::exit(2);
    }
    let reader = match PvsReader::open(args[1].as_ref()) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let data = reader.to_data().expect("decoding the sets");
    let bytes = citypvs::pvs::v1::write_v1(&data);
    let back = citypvs::pvs::v1::read_v1(&bytes).expect("reading the version 1 bytes back");
    assert_eq!(back.visible, data.visible);
    assert_eq!(back.cells, data.cells);
    std::fs::write(&args[2], &bytes).expect("writing the output");
    println!("{}: {} bytes", args[2], bytes.len());
}
