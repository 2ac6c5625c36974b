//! The part file: a finished shard (`citypvs bake --shard K/N`) or a bake's
//! checkpoint (`OUTPUT.citypvs-checkpoint`). Both hold the same header (the
//! input's SHA-256, every bake setting, the tool version, the frame, the
//! object ids, K, N, the total cell count and the cell range with its
//! triangles) and the visible sets of a prefix of the range (all of it for a
//! finished shard). Layout (docs/scale-out.md):
//!
//! ```text
//! magic "CPVSPART" | version u32 LE | reserved u32 | payload length u64 LE
//! | SHA-256 of the payload (32 bytes) | payload (bincode 2, standard config)
//! ```
//!
//! Reading checks the magic, the version, the length (truncation) and the
//! checksum (corruption) before decoding, decodes with a byte limit of a
//! small multiple of the payload's size (a hostile length prefix cannot make
//! it allocate beyond that), and then checks every field.

use std::io::Write;

use bincode::{Decode, Encode};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::input::Frame;
use crate::pvs::BakeInfo;
use crate::settings::{BakeNumbers, Settings};

/// The first eight bytes of every shard and checkpoint file.
pub const PART_MAGIC: [u8; 8] = *b"CPVSPART";
/// The part layout version this code writes and reads.
pub const PART_VERSION: u32 = 2;
/// Bytes before the payload: magic, version, reserved, length, checksum.
pub const PREAMBLE_BYTES: usize = 8 + 4 + 4 + 8 + 32;
/// Decoding may claim at most this many times the payload's size (plus
/// 64 KiB) in memory: enough for any honest file (a delta-coded object index
/// takes one byte in the file and four in memory; an object id's string
/// header 24 bytes for at least one byte in the file).
pub const DECODE_BUDGET_FACTOR: usize = 32;

/// What a part file is.
#[derive(Encode, Decode, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartKind {
    /// A finished shard: every cell of its range has its set.
    Shard,
    /// A bake's saved progress: a prefix of the range has its sets.
    Checkpoint,
}

/// Everything that decides a bake's result: two parts with equal keys (and
/// equal K, N and ranges) belong to the same bake.
#[derive(Encode, Decode, Clone, Debug)]
pub struct BakeKey {
    /// SHA-256 of the input file.
    pub source_hash: [u8; 32],
    /// Every bake number.
    pub numbers: BakeNumbers,
    /// [`Settings::region_hash`].
    pub region_hash: [u8; 32],
    /// The citypvs version that baked.
    pub tool_version: String,
}

impl BakeKey {
    /// The key of a bake of the input with hash `source_hash` under `settings`.
    pub fn of(source_hash: [u8; 32], settings: &Settings) -> BakeKey {
        BakeKey {
            source_hash,
            numbers: *settings.numbers(),
            region_hash: settings.region_hash(),
            tool_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }

    /// The names of the fields that differ (bit for bit), e.g. `["input", "eps"]`.
    pub fn differences(&self, other: &BakeKey) -> Vec<&'static str> {
        let mut out = Vec::new();
        if self.source_hash != other.source_hash {
            out.push("input");
        }
        out.extend(
            self.numbers
                .changed(&other.numbers)
                .into_iter()
                .map(|(name, _, _)| name),
        );
        if self.region_hash != other.region_hash {
            out.push("region");
        }
        if self.tool_version != other.tool_version {
            out.push("tool version");
        }
        out
    }
}

/// The input's frame, as stored in a part.
#[derive(Encode, Decode, Clone, Debug, PartialEq)]
pub enum FrameRecord {
    LonLat { lon0: f64, lat0: f64 },
    Metric { x: f64, y: f64, crs: Option<String> },
}

impl FrameRecord {
    pub fn of(frame: &Frame) -> FrameRecord {
        match frame {
            Frame::LonLat { lon0, lat0 } => FrameRecord::LonLat {
                lon0: *lon0,
                lat0: *lat0,
            },
            Frame::Metric { origin, crs } => FrameRecord::Metric {
                x: origin.x,
                y: origin.y,
                crs: crs.clone(),
            },
        }
    }

    pub fn to_frame(&self) -> Frame {
        match self {
            FrameRecord::LonLat { lon0, lat0 } => Frame::LonLat {
                lon0: *lon0,
                lat0: *lat0,
            },
            FrameRecord::Metric { x, y, crs } => Frame::Metric {
                origin: glam::DVec2::new(*x, *y),
                crs: crs.clone(),
            },
        }
    }
}

/// A shard or checkpoint, decoded.
#[derive(Encode, Decode, Clone, Debug)]
pub struct Part {
    pub kind: PartKind,
    pub key: BakeKey,
    pub frame: FrameRecord,
    /// K and N: this is shard K of N (a whole bake's checkpoint: 0 of 1).
    pub shard: u32,
    pub shards: u32,
    /// Cells of the whole bake.
    pub total_cells: u64,
    /// The range of cells (in cell order) this part covers.
    pub range_start: u64,
    pub range_end: u64,
    /// Object ids of the whole bake, index = object index.
    pub object_ids: Vec<String>,
    /// The objects' fingerprints (`crate::pvs::prints`), one per object.
    pub object_prints: Vec<crate::pvs::prints::ObjectPrint>,
    /// The triangles of the range's cells: x0 y0 x1 y1 x2 y2 in local metres.
    pub cells: Vec<[f64; 6]>,
    /// The sets of the first `set_lens.len()` cells of the range: the bytes
    /// each set takes in `set_runs`, where a set is its runs of consecutive
    /// indices, each as two LEB128 numbers (the run's start minus the end of
    /// the run before, or minus 0 for the first; the run's length minus 1).
    /// A cell that sees every object takes two bytes.
    pub set_lens: Vec<u32>,
    pub set_runs: Vec<u8>,
}

/// Counts and hashes the bytes written to it.
#[derive(Default)]
struct DigestWriter {
    hasher: Sha256,
    len: u64,
}

impl std::io::Write for DigestWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.hasher.update(buf);
        self.len += buf.len() as u64;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn push_leb128(out: &mut Vec<u8>, v: u32) {
    crate::pvs::codec::write_leb128(out, u64::from(v));
}

/// One LEB128 number of at most 32 bits from `bytes` at `*at`.
fn read_leb128(bytes: &[u8], at: &mut usize) -> Option<u32> {
    crate::pvs::codec::read_leb128_u32(bytes, at).ok()
}

/// Decode one set's run bytes, calling `f` with each member; `None` when
/// the bytes are malformed or a member would pass `u32::MAX`.
fn decode_runs(bytes: &[u8], mut f: impl FnMut(u32)) -> Option<()> {
    let (mut at, mut end) = (0usize, 0u64);
    while at < bytes.len() {
        let start = end + u64::from(read_leb128(bytes, &mut at)?);
        let len = u64::from(read_leb128(bytes, &mut at)?) + 1;
        if start + len > u64::from(u32::MAX) {
            return None;
        }
        for o in start..start + len {
            f(o as u32);
        }
        end = start + len;
    }
    Some(())
}

/// The sets in the run form a part stores (ascending indices each).
pub fn pack_sets<'a>(sets: impl IntoIterator<Item = &'a [u32]>) -> (Vec<u32>, Vec<u8>) {
    let (mut lens, mut runs) = (Vec::new(), Vec::new());
    for set in sets {
        let before = runs.len();
        let mut end = 0u32;
        let mut i = 0;
        while i < set.len() {
            let start = set[i];
            let mut j = i + 1;
            while j < set.len() && set[j] == set[j - 1] + 1 {
                j += 1;
            }
            push_leb128(&mut runs, start - end);
            push_leb128(&mut runs, (j - i - 1) as u32);
            end = set[j - 1] + 1;
            i = j;
        }
        lens.push((runs.len() - before) as u32);
    }
    (lens, runs)
}

/// Decode with a bincode byte limit of at least `budget` (a power of two).
fn decode_limited<T: Decode<()>>(
    payload: &[u8],
    budget: usize,
) -> std::result::Result<(T, usize), bincode::error::DecodeError> {
    use bincode::config::standard;
    macro_rules! limits {
        ($($shift:literal),*) => {
            $(
                if budget <= 1usize << $shift {
                    return bincode::decode_from_slice(payload, standard().with_limit::<{ 1usize << $shift }>());
                }
            )*
        };
    }
    limits!(16, 18, 20, 22, 24, 26, 28, 30, 32, 34, 36, 38);
    bincode::decode_from_slice(payload, standard().with_limit::<{ 1usize << 40 }>())
}

impl Part {
    /// The cells of the range.
    pub fn range_len(&self) -> usize {
        (self.range_end - self.range_start) as usize
    }

    /// Cells of the range that have their sets.
    pub fn done(&self) -> usize {
        self.set_lens.len()
    }

    /// Add the set of the next cell of the range.
    pub fn push_set(&mut self, set: &[u32]) {
        let (lens, runs) = pack_sets(std::iter::once(set));
        self.set_lens.extend(lens);
        self.set_runs.extend(runs);
    }

    /// Keep only the sets of the first `cells` cells.
    pub fn truncate_sets(&mut self, cells: usize) {
        let keep: usize = self.set_lens.iter().take(cells).map(|&l| l as usize).sum();
        self.set_lens.truncate(cells);
        self.set_runs.truncate(keep);
    }

    /// Hand the stored sets (ascending object indices) to `f` one at a
    /// time, in cell order, without expanding them all.
    pub fn for_each_set(&self, f: &mut dyn FnMut(&[u32]) -> Result<()>) -> Result<()> {
        let mut set = Vec::new();
        let mut at = 0;
        for &len in &self.set_lens {
            set.clear();
            let bytes = &self.set_runs[at..at + len as usize];
            decode_runs(bytes, |o| set.push(o))
                .ok_or_else(|| Error::format("a stored visible set is malformed"))?;
            at += len as usize;
            f(&set)?;
        }
        Ok(())
    }

    /// The stored sets, ascending object indices (checked when decoded).
    pub fn sets(&self) -> Vec<Vec<u32>> {
        let mut out = Vec::with_capacity(self.set_lens.len());
        self.for_each_set(&mut |s| {
            out.push(s.to_vec());
            Ok(())
        })
        .expect("sets are checked when decoded or built by push_set");
        out
    }

    /// The triangles of the range's cells.
    pub fn triangles(&self) -> Vec<[glam::DVec2; 3]> {
        use glam::DVec2;
        self.cells
            .iter()
            .map(|c| {
                [
                    DVec2::new(c[0], c[1]),
                    DVec2::new(c[2], c[3]),
                    DVec2::new(c[4], c[5]),
                ]
            })
            .collect()
    }

    /// The `.pvs` header of the bake this part belongs to.
    pub fn bake_info(&self) -> BakeInfo {
        BakeInfo {
            numbers: self.key.numbers,
            frame: self.frame.to_frame(),
            source_hash: self.key.source_hash,
            region_hash: self.key.region_hash,
            tool_version: self.key.tool_version.clone(),
        }
    }

    /// Whether `other` is a part of the same bake, over the same range, in
    /// the same frame with the same objects and cells: a checkpoint is only
    /// used when this holds. `None` when it does, else what differs.
    pub fn mismatch(&self, other: &Part) -> Option<String> {
        let keys = self.key.differences(&other.key);
        if !keys.is_empty() {
            return Some(keys.join(", "));
        }
        let mut out = Vec::new();
        if (self.shard, self.shards) != (other.shard, other.shards) {
            out.push("shard");
        }
        if (self.total_cells, self.range_start, self.range_end)
            != (other.total_cells, other.range_start, other.range_end)
        {
            out.push("cell range");
        }
        if self.frame != other.frame {
            out.push("frame");
        }
        if self.object_ids != other.object_ids || self.object_prints != other.object_prints {
            out.push("objects");
        }
        let bits = |c: &[[f64; 6]]| -> Vec<u64> {
            c.iter()
                .flat_map(|t| t.iter().map(|v| v.to_bits()))
                .collect()
        };
        if bits(&self.cells) != bits(&other.cells) {
            out.push("cells");
        }
        (!out.is_empty()).then(|| out.join(", "))
    }

    /// The file's bytes.
    pub fn encode(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        self.write_to(&mut out)
            .map_err(|e| Error::format(format!("cannot encode a part file: {e}")))?;
        Ok(out)
    }

    /// Write the file's bytes to `out` in two passes (one to learn the
    /// payload's length and digest for the preamble, one to write it), so
    /// that no copy of the sets is held beside the part.
    fn write_to(&self, mut out: &mut dyn Write) -> std::io::Result<()> {
        let config = bincode::config::standard();
        let mut digest = DigestWriter::default();
        bincode::encode_into_std_write(self, &mut digest, config).map_err(std::io::Error::other)?;
        out.write_all(&PART_MAGIC)?;
        out.write_all(&PART_VERSION.to_le_bytes())?;
        out.write_all(&0u32.to_le_bytes())?;
        out.write_all(&digest.len.to_le_bytes())?;
        out.write_all(&digest.hasher.finalize())?;
        bincode::encode_into_std_write(self, &mut out, config).map_err(std::io::Error::other)?;
        Ok(())
    }

    /// Write the file atomically (see [`Part::write_to`]).
    pub fn write(&self, path: &std::path::Path) -> Result<()> {
        crate::atomic::write_atomically_with(path, &mut |w| {
            let mut w = std::io::BufWriter::new(w);
            self.write_to(&mut w)?;
            w.flush()
        })
    }

    /// Read and check a part file; errors start with the file's name.
    pub fn read(path: &std::path::Path) -> Result<Part> {
        let bytes = std::fs::read(path)
            .map_err(|e| Error::io(format!("{}: cannot read: {e}", path.display())))?;
        Part::decode(&bytes).map_err(|e| e.context(path.display()))
    }

    /// Decode and check a part file's bytes.
    pub fn decode(bytes: &[u8]) -> Result<Part> {
        if bytes.len() < PART_MAGIC.len() || bytes[..8] != PART_MAGIC {
            return Err(Error::format(
                "not a citypvs shard or checkpoint file (wrong magic)",
            ));
        }
        if bytes.len() < PREAMBLE_BYTES {
            return Err(Error::format(format!(
                "truncated: {} bytes, shorter than the {PREAMBLE_BYTES}-byte preamble",
                bytes.len()
            )));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != PART_VERSION {
            return Err(Error::format(format!(
                "part layout version {version}, this citypvs reads version {PART_VERSION}"
            )));
        }
        let len = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
        let have = (bytes.len() - PREAMBLE_BYTES) as u64;
        if have < len {
            return Err(Error::format(format!(
                "truncated: the payload is {have} of {len} bytes"
            )));
        }
        if have > len {
            return Err(Error::format(format!(
                "{} bytes after the end of the payload",
                have - len
            )));
        }
        let payload = &bytes[PREAMBLE_BYTES..];
        if Sha256::digest(payload)[..] != bytes[24..56] {
            return Err(Error::format(
                "corrupted: the payload's SHA-256 does not match the checksum",
            ));
        }
        let budget = payload
            .len()
            .saturating_mul(DECODE_BUDGET_FACTOR)
            .saturating_add(1 << 16);
        let (part, used): (Part, usize) = decode_limited(payload, budget)
            .map_err(|e| Error::format(format!("invalid payload: {e}")))?;
        if used != payload.len() {
            return Err(Error::format(format!(
                "invalid payload: {} unread bytes",
                payload.len() - used
            )));
        }
        part.check()?;
        Ok(part)
    }

    /// Check every field for consistency.
    fn check(&self) -> Result<()> {
        let bad = |m: String| Err(Error::format(format!("invalid payload: {m}")));
        if self.shards == 0 || self.shard >= self.shards {
            return bad(format!("shard {} of {}", self.shard, self.shards));
        }
        if !(self.range_start <= self.range_end && self.range_end <= self.total_cells) {
            return bad(format!(
                "cell range {}..{} of {} cells",
                self.range_start, self.range_end, self.total_cells
            ));
        }
        let n = self.range_len();
        if self.cells.len() != n {
            return bad(format!(
                "{} cell triangles for a range of {n} cells",
                self.cells.len()
            ));
        }
        if !self.object_prints.is_empty() && self.object_prints.len() != self.object_ids.len() {
            return bad(format!(
                "{} object fingerprints for {} objects",
                self.object_prints.len(),
                self.object_ids.len()
            ));
        }
        if self.cells.iter().flatten().any(|v| !v.is_finite()) {
            return bad("a cell triangle has a non-finite coordinate".into());
        }
        if self.done() > n || (self.kind == PartKind::Shard && self.done() != n) {
            return bad(format!(
                "{} visible sets for a range of {n} cells",
                self.done()
            ));
        }
        let total: u64 = self.set_lens.iter().map(|&l| l as u64).sum();
        if total != self.set_runs.len() as u64 {
            return bad(format!(
                "the set lengths add up to {total} bytes, but {} are stored",
                self.set_runs.len()
            ));
        }
        let objects = self.object_ids.len() as u64;
        let mut at = 0;
        for (c, &len) in self.set_lens.iter().enumerate() {
            let cell = self.range_start + c as u64;
            let mut top = None;
            let bytes = &self.set_runs[at..at + len as usize];
            // Members only ever grow, so checking the last one of each run
            // suffices; stop at the first one out of range.
            let mut at_run = 0usize;
            let mut end = 0u64;
            while at_run < bytes.len() {
                let (Some(gap), Some(more)) = (
                    read_leb128(bytes, &mut at_run),
                    read_leb128(bytes, &mut at_run),
                ) else {
                    return bad(format!("the set of cell {cell} is malformed"));
                };
                let last = end + u64::from(gap) + u64::from(more);
                if last >= objects {
                    top = Some(last);
                    break;
                }
                end = last + 1;
            }
            if let Some(o) = top {
                return bad(format!(
                    "the set of cell {cell} holds object {o}, but there are {objects} objects"
                ));
            }
            at += len as usize;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part() -> Part {
        let sets: Vec<Vec<u32>> = vec![vec![0, 2, 5], vec![], vec![1]];
        let (set_lens, set_runs) = pack_sets(sets.iter().map(|s| s.as_slice()));
        Part {
            kind: PartKind::Shard,
            key: BakeKey::of([7; 32], &Settings::default()),
            frame: FrameRecord::LonLat {
                lon0: 24.9,
                lat0: 60.1,
            },
            shard: 1,
            shards: 3,
            total_cells: 9,
            range_start: 3,
            range_end: 6,
            object_ids: (0..6).map(|i| format!("b{i}")).collect(),
            object_prints: Vec::new(),
            cells: vec![[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]; 3],
            set_lens,
            set_runs,
        }
    }

    #[test]
    fn a_part_reads_back_with_its_sets() {
        let p = part();
        let q = Part::decode(&p.encode().unwrap()).unwrap();
        assert_eq!(q.sets(), vec![vec![0, 2, 5], vec![], vec![1]]);
        assert_eq!(p.mismatch(&q), None);
    }

    #[test]
    fn a_written_part_file_holds_exactly_the_encoded_bytes() {
        let p = part();
        let dir = std::env::temp_dir().join(format!("citypvs-part-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.part");
        p.write(&path).unwrap();
        let written = std::fs::read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(written, p.encode().unwrap());
        assert_eq!(Part::decode(&written).unwrap().sets(), p.sets());
    }

    #[test]
    fn truncation_corruption_and_bad_fields_are_refused() {
        let bytes = part().encode().unwrap();
        for cut in [0, 5, 30, bytes.len() - 1] {
            let err = Part::decode(&bytes[..cut]).unwrap_err();
            assert_eq!(err.kind(), &crate::ErrorKind::Format, "{err}");
        }
        let err = Part::decode(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(err.to_string().contains("truncated"), "{err}");
        let mut flipped = bytes.clone();
        *flipped.last_mut().unwrap() ^= 1;
        let err = Part::decode(&flipped).unwrap_err();
        assert!(err.to_string().contains("corrupted"), "{err}");
        // A well-formed file with an object index out of range.
        let mut p = part();
        p.set_runs[2] = 9;
        let err = Part::decode(&p.encode().unwrap()).unwrap_err();
        assert!(err.to_string().contains("holds object"), "{err}");
    }

    #[test]
    fn a_hostile_length_prefix_hits_the_limit_not_the_allocator() {
        // A valid preamble and checksum over a payload that claims 2^40 ids.
        let mut payload =
            bincode::encode_to_vec(PartKind::Shard, bincode::config::standard()).unwrap();
        let key = BakeKey::of([0; 32], &Settings::default());
        payload.extend(bincode::encode_to_vec(&key, bincode::config::standard()).unwrap());
        payload.extend(
            bincode::encode_to_vec(
                FrameRecord::LonLat {
                    lon0: 0.0,
                    lat0: 0.0,
                },
                bincode::config::standard(),
            )
            .unwrap(),
        );
        for v in [0u64, 1, 1, 0, 1] {
            payload.extend(bincode::encode_to_vec(v, bincode::config::standard()).unwrap());
        }
        payload.extend(bincode::encode_to_vec(1u64 << 40, bincode::config::standard()).unwrap());
        let mut bytes = Vec::new();
        bytes.extend_from_slice(&PART_MAGIC);
        bytes.extend_from_slice(&PART_VERSION.to_le_bytes());
        bytes.extend_from_slice(&0u32.to_le_bytes());
        bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&Sha256::digest(&payload));
        bytes.extend_from_slice(&payload);
        let err = Part::decode(&bytes).unwrap_err();
        assert_eq!(err.kind(), &crate::ErrorKind::Format, "{err}");
        assert!(err.to_string().contains("LimitExceeded"), "{err}");
    }
}
