//! Serialising [`PvsData`] to the version 1 byte layout (docs/FORMAT.md) and
//! writing it atomically.

use std::path::Path;

use sha2::{Digest, Sha256};

use super::codec::encode_all;
use super::{BakeInfo, FORMAT_VERSION, HEADER_BYTES, MAGIC, PvsData, WriteStats};
use crate::input::Frame;
use crate::{Error, Result};

/// Write the file atomically (temporary file in the same folder, then rename).
pub fn write_pvs(path: &Path, data: &PvsData) -> Result<WriteStats> {
    let (bytes, mut stats) = encode_pvs(data).map_err(|e| e.context(path.display()))?;
    crate::atomic::write_atomically(path, &bytes)?;
    stats.file_bytes = bytes.len() as u64;
    Ok(stats)
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}
fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}
fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_le_bytes());
}
fn put_str(out: &mut Vec<u8>, s: &str) -> Result<()> {
    let len = u32::try_from(s.len())
        .map_err(|_| Error::new(format!("string of {} bytes is too long", s.len())))?;
    put_u32(out, len);
    out.extend_from_slice(s.as_bytes());
    Ok(())
}
fn pad_to_8(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(8) {
        out.push(0);
    }
}
fn patch_u64(out: &mut [u8], at: usize, v: u64) {
    out[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

fn check(data: &PvsData) -> Result<()> {
    let n = data.object_ids.len();
    if u32::try_from(n).is_err() || u32::try_from(data.cells.len()).is_err() {
        return Err(Error::new("more than 2^32 - 1 objects or cells"));
    }
    if data.visible.len() != data.cells.len() {
        return Err(Error::new(format!(
            "{} cells but {} visible sets",
            data.cells.len(),
            data.visible.len()
        )));
    }
    for (c, tri) in data.cells.iter().enumerate() {
        if !tri.iter().all(|p| p.is_finite()) {
            return Err(Error::new(format!("cell {c} has a non-finite coordinate")));
        }
    }
    for (c, set) in data.visible.iter().enumerate() {
        if !set.windows(2).all(|w| w[0] < w[1]) {
            return Err(Error::new(format!(
                "visible set of cell {c} is not strictly ascending"
            )));
        }
        if let Some(&last) = set.last()
            && last as usize >= n
        {
            return Err(Error::new(format!(
                "visible set of cell {c} holds object {last}, but there are only {n} objects"
            )));
        }
    }
    Ok(())
}

fn put_header(out: &mut Vec<u8>, info: &BakeInfo, objects: u32, cells: u32) {
    out.extend_from_slice(&MAGIC);
    put_u32(out, FORMAT_VERSION);
    put_u32(out, 0); // flags
    put_u64(out, 0); // file_bytes, patched at the end
    for v in [
        info.eps,
        info.eye_height,
        info.pixel,
        info.max_cell_edge,
        info.margin,
    ] {
        put_f64(out, v);
    }
    let (kind, has_crs, x, y) = match &info.frame {
        Frame::LonLat { lon0, lat0 } => (0, 0, *lon0, *lat0),
        Frame::Metric { origin, crs } => (1, u32::from(crs.is_some()), origin.x, origin.y),
    };
    put_u32(out, kind);
    put_u32(out, has_crs);
    put_f64(out, x);
    put_f64(out, y);
    out.extend_from_slice(&info.source_hash);
    put_u32(out, objects);
    put_u32(out, cells);
    // objects_offset, cells_offset, index_offset, records_offset, records_bytes: patched below.
    for _ in 0..5 {
        put_u64(out, 0);
    }
    debug_assert_eq!(out.len(), HEADER_BYTES);
}

/// The complete file bytes and the size measurements (file_bytes filled in).
pub fn encode_pvs(data: &PvsData) -> Result<(Vec<u8>, WriteStats)> {
    check(data)?;
    let n = data.object_ids.len();
    let mut out = Vec::new();
    put_header(&mut out, &data.info, n as u32, data.cells.len() as u32);
    put_str(&mut out, &data.info.tool_version)?;
    if let Frame::Metric { crs: Some(crs), .. } = &data.info.frame {
        put_str(&mut out, crs)?;
    }
    let objects_offset = out.len();
    for id in &data.object_ids {
        put_str(&mut out, id)?;
    }
    pad_to_8(&mut out);
    let cells_offset = out.len();
    for tri in &data.cells {
        for p in tri {
            put_f64(&mut out, p.x);
            put_f64(&mut out, p.y);
        }
    }
    let index_offset = out.len();
    let (records, sizes) = encode_all(&data.visible, n);
    let mut at = 0u64;
    put_u64(&mut out, at);
    for r in &records {
        at += r.len() as u64;
        put_u64(&mut out, at);
    }
    let records_offset = out.len();
    for r in &records {
        out.extend_from_slice(r);
    }
    let records_bytes = at;
    let file_bytes = out.len() + 32;
    patch_u64(&mut out, 16, file_bytes as u64);
    for (k, v) in [
        objects_offset,
        cells_offset,
        index_offset,
        records_offset,
        records_bytes as usize,
    ]
    .into_iter()
    .enumerate()
    {
        patch_u64(&mut out, 128 + 8 * k, v as u64);
    }
    let digest = Sha256::digest(&out);
    out.extend_from_slice(&digest);

    debug_assert_eq!(sizes.chosen, records_bytes);
    let stats = WriteStats {
        file_bytes: out.len() as u64,
        record_bytes: records_bytes,
        raw_bitset_bytes: sizes.raw_bitset,
        rle_bitset_bytes: sizes.quake_rle,
    };
    Ok((out, stats))
}
