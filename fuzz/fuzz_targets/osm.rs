//! Fuzz target: the OpenStreetMap PBF reader, through the library's
//! read-from-bytes entry. Any input must give a city or an error, never a
//! panic, an abort, a hang or memory out of proportion to the file.
//!
//! The first byte chooses how the rest is fed: with bit 0 clear, as a
//! whole file; with it set, as one `PrimitiveBlock` message, put into a
//! file as the uncompressed blob after a header blob, so that mutations
//! reach the element decoding and the building assembly instead of
//! failing the framing or the compression.
#![no_main]

use citypvs::input::{Format, InputOptions, read_city_bytes};
use libfuzzer_sys::fuzz_target;

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn bytes_field(out: &mut Vec<u8>, field: u64, data: &[u8]) {
    varint(out, field << 3 | 2);
    varint(out, data.len() as u64);
    out.extend_from_slice(data);
}

fn int_field(out: &mut Vec<u8>, field: u64, v: u64) {
    varint(out, field << 3);
    varint(out, v);
}

/// A blob of type `kind` holding `message` uncompressed, with its header.
fn blob(out: &mut Vec<u8>, kind: &[u8], message: &[u8]) {
    let mut blob = Vec::new();
    bytes_field(&mut blob, 1, message);
    int_field(&mut blob, 2, message.len() as u64);
    let mut header = Vec::new();
    bytes_field(&mut header, 1, kind);
    int_field(&mut header, 3, blob.len() as u64);
    out.extend_from_slice(&(header.len() as u32).to_be_bytes());
    out.extend_from_slice(&header);
    out.extend_from_slice(&blob);
}

fuzz_target!(|data: &[u8]| {
    let Some((&how, rest)) = data.split_first() else {
        return;
    };
    let options = InputOptions {
        format: Some(Format::OsmPbf),
        ..InputOptions::default()
    };
    if how & 1 == 0 {
        let _ = read_city_bytes(rest, "fuzz.osm.pbf", &options);
        return;
    }
    let mut file = Vec::new();
    let mut header = Vec::new();
    bytes_field(&mut header, 4, b"OsmSchema-V0.6");
    blob(&mut file, b"OSMHeader", &header);
    blob(&mut file, b"OSMData", rest);
    let _ = read_city_bytes(&file, "fuzz.osm.pbf", &options);
});
