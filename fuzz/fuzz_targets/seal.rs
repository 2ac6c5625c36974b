//! The preamble a part file and a geometry cache put before their payload
//! (magic, layout version, 4 reserved bytes, the payload's length and
//! SHA-256), for the targets that feed a payload sealed so that mutations
//! get past those checks.

use sha2::{Digest, Sha256};

/// `payload` with a correct preamble of `magic` and `version` in front.
pub fn sealed(magic: &[u8; 8], version: u32, payload: &[u8]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(56 + payload.len());
    bytes.extend_from_slice(magic);
    bytes.extend_from_slice(&version.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&Sha256::digest(payload));
    bytes.extend_from_slice(payload);
    bytes
}
