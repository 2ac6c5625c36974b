//! The per-record codings of version 1 (still used to measure the
//! alternatives and by the version 1 converter), raw bitsets and Quake's
//! zero-byte run-length coding for comparison, and LEB128 varints.
//!
//! A record is one tag byte followed by the payload of the coding it names.
//! The writer tries every coding and keeps the shortest (ties go to the lowest
//! tag), so each record is never more than one byte longer than the raw bitset.

use serde::Serialize;

/// Gaps between ascending indices as LEB128 varints.
pub const TAG_GAPS: u8 = 0;
/// Bitset, least significant bit first, trailing zero bytes dropped.
pub const TAG_BITSET: u8 = 1;
/// Bitset with zero bytes run-length coded (Quake vis), trailing zero bytes dropped.
pub const TAG_ZERO_RLE: u8 = 2;
/// Alternating lengths of runs of absent and present indices as LEB128 varints.
pub const TAG_RUNS: u8 = 3;

/// Names of the tags, index = tag.
pub const TAG_NAMES: [&str; 4] = ["gaps", "bitset", "zero-rle", "runs"];

/// Append `v` as an unsigned LEB128 varint (7 bits per byte, low first, high bit = more).
pub fn write_leb128(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(byte);
            return;
        }
        out.push(byte | 0x80);
    }
}

/// Read a LEB128 varint holding a value below 2^32 (at most 5 bytes).
pub fn read_leb128_u32(bytes: &[u8], pos: &mut usize) -> Result<u32, String> {
    let mut value: u64 = 0;
    for i in 0..5 {
        let Some(&byte) = bytes.get(*pos) else {
            return Err("varint runs past the end of the record".into());
        };
        *pos += 1;
        value |= u64::from(byte & 0x7f) << (7 * i);
        if byte & 0x80 == 0 {
            return u32::try_from(value).map_err(|_| "varint exceeds 2^32 - 1".to_string());
        }
    }
    Err("varint longer than 5 bytes".into())
}

/// Bytes of a full bitset for `n` objects.
pub fn bitset_len(n: usize) -> usize {
    n.div_ceil(8)
}

/// The full bitset of `set` over `n` objects: bit `i % 8` of byte `i / 8` is object `i`.
pub fn bitset(set: &[u32], n: usize) -> Vec<u8> {
    let mut bits = vec![0u8; bitset_len(n)];
    for &i in set {
        bits[i as usize / 8] |= 1 << (i % 8);
    }
    bits
}

/// Quake's vis coding of a bitset: a non-zero byte stands for itself; a zero
/// byte is followed by a count byte (1..=255) of zero bytes it stands for.
pub fn zero_rle(bits: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bits.len() {
        if bits[i] != 0 {
            out.push(bits[i]);
            i += 1;
            continue;
        }
        let mut run = 1;
        while i + run < bits.len() && bits[i + run] == 0 && run < 255 {
            run += 1;
        }
        out.push(0);
        out.push(run as u8);
        i += run;
    }
    out
}

/// Length of [`zero_rle`] of the full bitset of `set` (ascending, below `n`)
/// over `n` objects, computed without building the bitset.
pub fn zero_rle_len(set: &[u32], n: usize) -> u64 {
    let total = bitset_len(n) as u64;
    let zero_run = |z: u64| 2 * z.div_ceil(255);
    let mut bytes = 0u64;
    let mut next_byte = 0u64; // first byte not yet accounted for
    let mut k = 0;
    while k < set.len() {
        let b = u64::from(set[k] / 8);
        while k < set.len() && u64::from(set[k] / 8) == b {
            k += 1;
        }
        bytes += zero_run(b - next_byte) + 1;
        next_byte = b + 1;
    }
    bytes + zero_run(total.saturating_sub(next_byte))
}

fn trim_trailing_zeros(mut bits: Vec<u8>) -> Vec<u8> {
    while bits.last() == Some(&0) {
        bits.pop();
    }
    bits
}

fn encode_gaps(set: &[u32]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut next = 0u64; // smallest index the next entry may have
    for &i in set {
        write_leb128(&mut out, u64::from(i) - next);
        next = u64::from(i) + 1;
    }
    out
}

fn encode_runs(set: &[u32]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut next = 0u64;
    let mut k = 0;
    while k < set.len() {
        let start = set[k];
        let mut end = k + 1;
        while end < set.len() && set[end] == set[end - 1] + 1 {
            end += 1;
        }
        write_leb128(&mut out, u64::from(start) - next);
        write_leb128(&mut out, (end - k - 1) as u64);
        next = u64::from(set[end - 1]) + 2; // a run is followed by at least one absent index
        k = end;
    }
    out
}

/// The record payload of each coding, index = tag.
fn payloads(set: &[u32], n: usize) -> [Vec<u8>; 4] {
    let bits = trim_trailing_zeros(bitset(set, n));
    let rle = zero_rle(&bits);
    [encode_gaps(set), bits, rle, encode_runs(set)]
}

/// The record for an ascending set of indices below `n`: the shortest coding, tag first.
pub fn encode_record(set: &[u32], n: usize) -> Vec<u8> {
    let candidates = payloads(set, n);
    let (tag, payload) = candidates
        .iter()
        .enumerate()
        .min_by_key(|(tag, p)| (p.len(), *tag))
        .expect("four candidates");
    let mut out = Vec::with_capacity(payload.len() + 1);
    out.push(tag as u8);
    out.extend_from_slice(payload);
    out
}

/// Decode a record back to ascending indices below `n`, rejecting any malformed record.
pub fn decode_record(record: &[u8], n: usize) -> Result<Vec<u32>, String> {
    let Some((&tag, payload)) = record.split_first() else {
        return Err("empty record (no tag byte)".into());
    };
    let set = match tag {
        TAG_GAPS => decode_gaps(payload)?,
        TAG_BITSET => decode_bits(payload, n)?,
        TAG_ZERO_RLE => decode_bits(&expand_zero_rle(payload, bitset_len(n))?, n)?,
        TAG_RUNS => decode_runs(payload, n)?,
        other => return Err(format!("unknown record tag {other}")),
    };
    if let Some(&last) = set.last()
        && last as usize >= n
    {
        return Err(format!(
            "object index {last} is out of range (the file has {n} objects)"
        ));
    }
    Ok(set)
}

fn decode_gaps(payload: &[u8]) -> Result<Vec<u32>, String> {
    let mut out = Vec::new();
    let mut pos = 0;
    let mut next = 0u64;
    while pos < payload.len() {
        let index = next + u64::from(read_leb128_u32(payload, &mut pos)?);
        let index = u32::try_from(index).map_err(|_| "object index exceeds 2^32 - 1")?;
        out.push(index);
        next = u64::from(index) + 1;
    }
    Ok(out)
}

fn decode_runs(payload: &[u8], n: usize) -> Result<Vec<u32>, String> {
    let mut out = Vec::new();
    let mut pos = 0;
    let mut next = 0u64;
    while pos < payload.len() {
        let start = next + u64::from(read_leb128_u32(payload, &mut pos)?);
        if pos >= payload.len() {
            return Err("run start without a run length".into());
        }
        let extra = u64::from(read_leb128_u32(payload, &mut pos)?);
        let last = start + extra;
        // Checked before expanding, so a corrupt length cannot allocate much.
        if last >= n as u64 {
            return Err(format!(
                "object index {last} is out of range (the file has {n} objects)"
            ));
        }
        out.extend(start as u32..=last as u32);
        next = last + 2;
    }
    Ok(out)
}

fn expand_zero_rle(payload: &[u8], max_len: usize) -> Result<Vec<u8>, String> {
    let mut bits = Vec::new();
    let mut pos = 0;
    while pos < payload.len() {
        let byte = payload[pos];
        pos += 1;
        if byte != 0 {
            bits.push(byte);
        } else {
            let Some(&count) = payload.get(pos) else {
                return Err("zero byte without a count at the end of the record".into());
            };
            pos += 1;
            if count == 0 {
                return Err("zero run with count 0".into());
            }
            bits.resize(bits.len() + count as usize, 0);
        }
        if bits.len() > max_len {
            return Err("bitset longer than the object table".into());
        }
    }
    Ok(bits)
}

fn decode_bits(bits: &[u8], n: usize) -> Result<Vec<u32>, String> {
    if bits.len() > bitset_len(n) {
        return Err("bitset longer than the object table".into());
    }
    let mut out = Vec::new();
    for (k, &byte) in bits.iter().enumerate() {
        for b in 0..8 {
            if byte & (1 << b) != 0 {
                out.push((k * 8 + b) as u32);
            }
        }
    }
    Ok(out)
}

/// Total bytes of a set of visible sets under each candidate coding.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SchemeSizes {
    /// Records as written (tag byte plus the shortest payload).
    pub chosen: u64,
    /// Full raw bitsets, ceil(objects / 8) bytes per cell.
    pub raw_bitset: u64,
    /// Quake vis: full bitsets with zero bytes run-length coded.
    pub quake_rle: u64,
    /// Only gap varints (no tag byte).
    pub gaps: u64,
    /// Only run-length varints (no tag byte).
    pub runs: u64,
    /// How many records use each tag, index = tag.
    pub tag_counts: [u64; 4],
}

/// The record and its sizes under every coding, for one set.
fn encode_and_measure(set: &[u32], n: usize) -> (Vec<u8>, SchemeSizes) {
    let record = encode_record(set, n);
    let mut s = SchemeSizes {
        chosen: record.len() as u64,
        raw_bitset: bitset_len(n) as u64,
        quake_rle: zero_rle_len(set, n),
        gaps: encode_gaps(set).len() as u64,
        runs: encode_runs(set).len() as u64,
        tag_counts: [0; 4],
    };
    s.tag_counts[record[0] as usize] = 1;
    (record, s)
}

impl SchemeSizes {
    fn add(&mut self, o: &SchemeSizes) {
        self.chosen += o.chosen;
        self.raw_bitset += o.raw_bitset;
        self.quake_rle += o.quake_rle;
        self.gaps += o.gaps;
        self.runs += o.runs;
        for (a, b) in self.tag_counts.iter_mut().zip(o.tag_counts) {
            *a += b;
        }
    }
}

/// Measure every coding over `sets` (ascending indices below `n`).
pub fn measure<'a>(sets: impl IntoIterator<Item = &'a [u32]>, n: usize) -> SchemeSizes {
    let mut total = SchemeSizes::default();
    for set in sets {
        total.add(&encode_and_measure(set, n).1);
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn decode_with(tag: u8, set: &[u32], n: usize) -> Vec<u32> {
        let mut record = vec![tag];
        record.extend_from_slice(&payloads(set, n)[tag as usize]);
        decode_record(&record, n).unwrap()
    }

    #[test]
    fn leb128_known_bytes() {
        let mut out = Vec::new();
        write_leb128(&mut out, 0);
        write_leb128(&mut out, 127);
        write_leb128(&mut out, 128);
        write_leb128(&mut out, 300);
        assert_eq!(out, [0x00, 0x7f, 0x80, 0x01, 0xac, 0x02]);
    }

    #[test]
    fn quake_rle_known_bytes() {
        assert_eq!(zero_rle(&[5, 0, 0, 0, 7, 0]), [5, 0, 3, 7, 0, 1]);
        let long = vec![0u8; 300];
        assert_eq!(zero_rle(&long), [0, 255, 0, 45]);
    }

    #[test]
    fn record_codings_known_bytes() {
        // {1, 2, 3, 10} over 16 objects.
        let set = [1, 2, 3, 10];
        let p = payloads(&set, 16);
        assert_eq!(p[TAG_GAPS as usize], [1, 0, 0, 6]);
        assert_eq!(p[TAG_BITSET as usize], [0b0000_1110, 0b0000_0100]);
        assert_eq!(p[TAG_RUNS as usize], [1, 2, 5, 0]);
        assert_eq!(
            encode_record(&set, 16),
            [TAG_BITSET, 0b0000_1110, 0b0000_0100]
        );
    }

    #[test]
    fn malformed_records_are_errors() {
        assert!(decode_record(&[], 8).is_err());
        assert!(decode_record(&[9], 8).is_err());
        assert!(decode_record(&[TAG_GAPS, 0x80], 8).is_err());
        assert!(decode_record(&[TAG_GAPS, 8], 8).is_err()); // index 8 of 8
        assert!(decode_record(&[TAG_BITSET, 0, 1], 8).is_err()); // too long
        assert!(decode_record(&[TAG_ZERO_RLE, 0], 8).is_err());
        assert!(decode_record(&[TAG_ZERO_RLE, 0, 0], 8).is_err());
        assert!(decode_record(&[TAG_RUNS, 3], 8).is_err());
        assert!(decode_record(&[TAG_RUNS, 0, 0xff, 0xff, 0xff, 0xff, 0x0f], 8).is_err());
        assert_eq!(decode_record(&[TAG_GAPS], 8).unwrap(), Vec::<u32>::new());
    }

    proptest! {
        #[test]
        fn every_coding_round_trips(n in 1usize..2000, picks in proptest::collection::vec(any::<u32>(), 0..300)) {
            let mut set: Vec<u32> = picks.iter().map(|p| p % n as u32).collect();
            set.sort_unstable();
            set.dedup();
            for tag in 0..4u8 {
                prop_assert_eq!(decode_with(tag, &set, n), set.clone());
            }
            let record = encode_record(&set, n);
            prop_assert!(record.len() <= bitset_len(n) + 1);
            prop_assert_eq!(decode_record(&record, n).unwrap(), set);
        }

        #[test]
        fn zero_rle_len_matches(n in 1usize..5000, picks in proptest::collection::vec(any::<u32>(), 0..300)) {
            let mut set: Vec<u32> = picks.iter().map(|p| p % n as u32).collect();
            set.sort_unstable();
            set.dedup();
            prop_assert_eq!(zero_rle_len(&set, n), zero_rle(&bitset(&set, n)).len() as u64);
        }

        #[test]
        fn arbitrary_records_never_panic(n in 0usize..100, record in proptest::collection::vec(any::<u8>(), 0..40)) {
            if let Ok(set) = decode_record(&record, n) {
                prop_assert!(set.windows(2).all(|w| w[0] < w[1]));
                prop_assert!(set.iter().all(|&i| (i as usize) < n));
            }
        }
    }
}
