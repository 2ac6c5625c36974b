//! Sealed files: the layout shared by the part files (shards and
//! checkpoints, `super::part`) and the geometry cache
//! (`super::geometry_cache`):
//!
//! ```text
//! magic (8 bytes) | version u32 LE | reserved u32 | payload length u64 LE
//! | SHA-256 of the payload (32 bytes) | payload (bincode 2, standard config)
//! ```
//!
//! Owns writing that preamble and its payload in two passes (the payload is
//! never held whole), and reading it back: the magic, the version, the
//! length (truncation) and the checksum (corruption) are checked before the
//! payload is decoded, with a byte limit of a small multiple of its size (a
//! hostile length prefix cannot make the reader allocate beyond that), and
//! the whole payload must be read. What the payload holds is checked by
//! each format.

use std::io::Write;

use bincode::{Decode, Encode};
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};

/// Bytes before the payload: magic, version, reserved, length, checksum.
pub const PREAMBLE_BYTES: usize = 8 + 4 + 4 + 8 + 32;
/// Decoding may claim at most this many times the payload's size (plus
/// 64 KiB) in memory: enough for any honest file (a delta-coded object index
/// takes one byte in the file and four in memory; an object id's string
/// header 24 bytes for at least one byte in the file).
pub const DECODE_BUDGET_FACTOR: usize = 32;

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

/// The payload of a sealed file is (magic, layout version,
/// 4 reserved bytes, payload length, SHA-256 of the payload, payload), once
/// every field of that preamble is checked; `what` names the kind of file
/// in the error when the magic is wrong.
fn checked_payload<'a>(
    bytes: &'a [u8],
    magic: &[u8; 8],
    version: u32,
    what: &str,
) -> Result<&'a [u8]> {
    if bytes.len() < magic.len() || bytes[..8] != magic[..] {
        return Err(Error::format(format!("not {what} (wrong magic)")));
    }
    if bytes.len() < PREAMBLE_BYTES {
        return Err(Error::format(format!(
            "truncated: {} bytes, shorter than the {PREAMBLE_BYTES}-byte preamble",
            bytes.len()
        )));
    }
    let found = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if found != version {
        return Err(Error::format(format!(
            "layout version {found}, this citypvs reads version {version}"
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
    Ok(payload)
}

/// The value coded in the payload of a sealed file (see
/// [`checked_payload`]), decoded with a bincode byte limit of
/// [`DECODE_BUDGET_FACTOR`] times the payload's size (plus 64 KiB), so that
/// no length prefix in a crafted file makes the reader allocate more; the
/// whole payload must be read.
pub(crate) fn decode_sealed<T: Decode<()>>(
    bytes: &[u8],
    magic: &[u8; 8],
    version: u32,
    what: &str,
) -> Result<T> {
    let payload = checked_payload(bytes, magic, version, what)?;
    let budget = payload
        .len()
        .saturating_mul(DECODE_BUDGET_FACTOR)
        .saturating_add(1 << 16);
    let (value, used): (T, usize) = decode_limited(payload, budget)
        .map_err(|e| Error::format(format!("invalid payload: {e}")))?;
    if used != payload.len() {
        return Err(Error::format(format!(
            "invalid payload: {} unread bytes",
            payload.len() - used
        )));
    }
    Ok(value)
}

/// Write `value` as the bincode payload of a sealed file
/// (see [`checked_payload`]), in two passes (one to learn the payload's
/// length and digest for the preamble, one to write it), so that the
/// payload is never held whole.
pub(crate) fn write_sealed(
    mut out: &mut dyn Write,
    magic: &[u8; 8],
    version: u32,
    value: &impl Encode,
) -> std::io::Result<()> {
    let config = bincode::config::standard();
    let mut digest = DigestWriter::default();
    bincode::encode_into_std_write(value, &mut digest, config).map_err(std::io::Error::other)?;
    out.write_all(&preamble(
        magic,
        version,
        digest.len,
        &digest.hasher.finalize(),
    ))?;
    bincode::encode_into_std_write(value, &mut out, config).map_err(std::io::Error::other)?;
    Ok(())
}

/// The preamble of [`checked_payload`] for `payload`.
fn preamble(magic: &[u8; 8], version: u32, payload_len: u64, digest: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(PREAMBLE_BYTES);
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&payload_len.to_le_bytes());
    out.extend_from_slice(digest);
    out
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

/// `payload` (bytes coded however the caller likes) with a correct
/// preamble of `magic` and `version` in front: what tests and fuzz targets
/// use to get a crafted payload past the preamble's checks.
pub fn seal(magic: &[u8; 8], version: u32, payload: &[u8]) -> Vec<u8> {
    let mut bytes = preamble(
        magic,
        version,
        payload.len() as u64,
        &Sha256::digest(payload),
    );
    bytes.extend_from_slice(payload);
    bytes
}
