//! Fuzz target: the shard and checkpoint reader (`citypvs::scale::part`,
//! docs/scale-out.md). A part that reads must hand out its sets, go on as
//! a checkpoint and write its `.pvs` bytes with a result or an error, never
//! a panic, an abort or a hang.
//!
//! The input is a part's **payload** (a shard or checkpoint file without
//! its 56-byte preamble). It is fed twice: as a whole file as it is (the
//! magic and preamble checks), and sealed: the preamble (magic, layout
//! version, reserved, the payload's length and SHA-256) is put in front,
//! so that mutations reach the payload's decoding, the field checks, the
//! gap-coded sets and the block decoder.
//!
//! The seeds in `corpus/part` are payloads of small shards and checkpoints.
#![no_main]


use citypvs::scale::part::{PART_MAGIC, PART_VERSION, Part, PartBuilder, encode_parts};
use libfuzzer_sys::fuzz_target;

fn exercise(bytes: &[u8]) {
    let Ok(part) = Part::decode(bytes) else {
        return;
    };
    let n = part.object_ids.len() as u32;
    let mut cells = 0usize;
    let read = part.for_each_set(&mut |set| {
        assert!(set.windows(2).all(|w| w[0] < w[1]), "set not ascending");
        assert!(set.iter().all(|&i| i < n), "object index out of range");
        cells += 1;
        Ok(())
    });
    if read.is_ok() {
        assert_eq!(cells, part.done(), "sets handed out");
    }
    let _ = encode_parts(&part, &[&part]);
    // Going on from it as a checkpoint, with every cell left seeing nothing.
    if let Ok(mut builder) = PartBuilder::new(part.clone()) {
        for _ in part.done()..part.range_len() {
            builder.push(&[]);
        }
        let done = builder.into_part();
        assert_eq!(done.done(), done.range_len(), "every cell has a set");
        let _ = encode_parts(&done, &[&done]);
    }
}

fuzz_target!(|payload: &[u8]| {
    exercise(payload);
    exercise(&citypvs::scale::sealed::seal(&PART_MAGIC, PART_VERSION, payload));
});
