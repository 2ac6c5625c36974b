//! The old version 1 layout, read whole into a [`PvsData`]: only so that
//! measurements and tools can convert files baked before version 2 (the
//! ordinary reader, [`super::PvsReader`], refuses version 1). Fields that
//! version 1 did not store (near field, minimum gap, region hash) come back
//! as 0 / zeros.

use glam::DVec2;
use sha2::{Digest, Sha256};

use super::codec::decode_record;
use super::read::Cursor;
use super::write::{put_header_start, put_u32, put_u64};
use super::{BakeInfo, MAGIC, PvsData};
use crate::BakeNumbers;
use crate::frame::Frame;

const V1_HEADER_BYTES: usize = 168;
use crate::{Error, Result};

/// A string with a u32 length, as version 1 wrote them.
fn v1_string(c: &mut Cursor, what: &str) -> Result<String> {
    let len = c.u32(what)? as usize;
    let raw = c.take(len, what)?;
    String::from_utf8(raw.to_vec()).map_err(|_| Error::format(format!("{what} is not valid UTF-8")))
}

/// Check that the writer's recorded offset matches where the cursor is.
fn expect_at(c: &Cursor, offset: u64, what: &str) -> Result<()> {
    if offset != c.pos as u64 {
        return Err(Error::format(format!(
            "header says the {what} start at byte {offset}, but they start at byte {}",
            c.pos
        )));
    }
    Ok(())
}

/// Skip the zero bytes up to the next multiple of 8.
fn skip_padding(c: &mut Cursor) -> Result<()> {
    while !c.pos.is_multiple_of(8) {
        if c.take(1, "padding")?[0] != 0 {
            return Err(Error::format(format!(
                "padding byte {} is not zero",
                c.pos - 1
            )));
        }
    }
    Ok(())
}

/// Decode a whole version 1 file (checksum checked).
pub fn read_v1(bytes: &[u8]) -> Result<PvsData> {
    if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
        return Err(Error::format("not a citypvs .pvs file (bad magic bytes)"));
    }
    let mut c = Cursor::at(bytes, MAGIC.len(), "file");
    if c.u32("version")? != 1 {
        return Err(Error::format("not a version 1 file"));
    }
    let _flags = c.u32("flags")?;
    let file_bytes = c.u64("file length")?;
    if file_bytes != bytes.len() as u64 || bytes.len() < V1_HEADER_BYTES + 32 {
        return Err(Error::format("truncated version 1 file"));
    }
    let body = bytes.len() - 32;
    if Sha256::digest(&bytes[..body]).as_slice() != &bytes[body..] {
        return Err(Error::format("checksum mismatch"));
    }
    let c = &mut Cursor::at(&bytes[..body], c.pos, "file");
    let (info, object_ids, cells, ranges) = parse_body(c, body)?;
    let visible = (0..cells.len())
        .map(|k| {
            decode_record(&bytes[ranges[k]..ranges[k + 1]], object_ids.len())
                .map_err(|e| Error::format(format!("visible set of cell {k}: {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(PvsData {
        object_prints: Vec::new(),
        info,
        object_ids,
        cells,
        visible,
    })
}

type Body = (BakeInfo, Vec<String>, Vec<[DVec2; 3]>, Vec<usize>);

fn parse_body(c: &mut Cursor, body: usize) -> Result<Body> {
    // Version 1 has neither a near field nor a minimum gap: they read as 0.
    let mut params = [0.0; 7];
    for (v, name) in params.iter_mut().zip(&BakeNumbers::NAMES[..5]) {
        *v = c.f64(name)?;
    }
    let kind = c.u32("frame kind")?;
    let has_crs = c.u32("CRS flag")?;
    let fx = c.f64("frame x")?;
    let fy = c.f64("frame y")?;
    let source_hash: [u8; 32] = c.take(32, "source hash")?.try_into().unwrap();
    let object_count = c.u32("object count")? as usize;
    let cell_count = c.u32("cell count")? as usize;
    let objects_offset = c.u64("objects offset")?;
    let cells_offset = c.u64("cells offset")?;
    let index_offset = c.u64("record index offset")?;
    let records_offset = c.u64("records offset")?;
    let records_bytes = c.u64("records length")?;
    debug_assert_eq!(c.pos, V1_HEADER_BYTES);
    let tool_version = v1_string(c, "tool version")?;
    let frame = match (kind, has_crs) {
        (0, 0) => Frame::LonLat { lon0: fx, lat0: fy },
        (1, 0 | 1) => Frame::Metric {
            origin: DVec2::new(fx, fy),
            crs: if has_crs == 1 {
                Some(v1_string(c, "CRS name")?)
            } else {
                None
            },
        },
        _ => {
            return Err(Error::format(format!(
                "unknown frame kind {kind} with CRS flag {has_crs}"
            )));
        }
    };
    if !(fx.is_finite() && fy.is_finite()) {
        return Err(Error::format("frame origin is not finite"));
    }
    expect_at(c, objects_offset, "object ids")?;
    // Each id needs at least its 4-byte length: bound the count before allocating.
    if object_count > (body - c.pos) / 4 {
        return Err(Error::format(format!(
            "header claims {object_count} objects, more than the file can hold"
        )));
    }
    let mut object_ids = Vec::with_capacity(object_count);
    for k in 0..object_count {
        object_ids.push(v1_string(c, &format!("id of object {k}"))?);
    }
    skip_padding(c)?;
    expect_at(c, cells_offset, "cells")?;
    if cell_count > (body - c.pos) / 56 {
        return Err(Error::format(format!(
            "header claims {cell_count} cells, more than the file can hold"
        )));
    }
    let mut cells = Vec::with_capacity(cell_count);
    for k in 0..cell_count {
        let mut tri = [DVec2::ZERO; 3];
        for p in &mut tri {
            let what = format!("triangle of cell {k}");
            *p = DVec2::new(c.f64(&what)?, c.f64(&what)?);
            if !p.is_finite() {
                return Err(Error::format(format!(
                    "cell {k} has a non-finite coordinate"
                )));
            }
        }
        cells.push(tri);
    }
    expect_at(c, index_offset, "record offsets")?;
    let index_end = index_offset + 8 * (cell_count as u64 + 1);
    if records_offset != index_end {
        return Err(Error::format(format!(
            "header says the records start at byte {records_offset}, expected {index_end}"
        )));
    }
    if records_offset.checked_add(records_bytes) != Some(body as u64) {
        return Err(Error::format(format!(
            "records of {records_bytes} bytes from byte {records_offset} do not end where the checksum starts (byte {body})"
        )));
    }
    let mut ranges = Vec::with_capacity(cell_count + 1);
    let mut previous = 0u64;
    for k in 0..=cell_count {
        let at = c.u64("record offset")?;
        if (k == 0 && at != 0) || at < previous || at > records_bytes {
            return Err(Error::format(format!(
                "record offset {k} ({at}) is out of order or out of range"
            )));
        }
        previous = at;
        ranges.push((records_offset + at) as usize);
    }
    if previous != records_bytes {
        return Err(Error::format(format!(
            "record offsets end at {previous}, but the records take {records_bytes} bytes"
        )));
    }
    let info = BakeInfo {
        numbers: BakeNumbers::from_values(params),
        frame,
        source_hash,
        region_hash: [0; 32],
        tool_version,
    };
    Ok((info, object_ids, cells, ranges))
}

/// Write `data` in the version 1 layout (object ids in input order, 48-byte
/// triangles, one record per cell as [`super::codec::encode_record`] gives
/// it): only so that measurements can set version 2 beside version 1 and
/// general-purpose compressors of it. [`read_v1`] reads it back.
pub fn write_v1(data: &PvsData) -> Vec<u8> {
    fn strs(out: &mut Vec<u8>, s: &str) {
        put_u32(out, s.len() as u32);
        out.extend_from_slice(s.as_bytes());
    }
    let info = &data.info;
    let mut out = Vec::new();
    let crs = put_header_start(&mut out, 1, &info.numbers.values()[..5], &info.frame);
    out.extend_from_slice(&info.source_hash);
    put_u32(&mut out, data.object_ids.len() as u32);
    put_u32(&mut out, data.cells.len() as u32);
    let offsets_at = out.len();
    out.resize(V1_HEADER_BYTES, 0);
    strs(&mut out, &info.tool_version);
    if let Some(crs) = crs {
        strs(&mut out, crs);
    }
    let objects = out.len() as u64;
    for id in &data.object_ids {
        strs(&mut out, id);
    }
    while !out.len().is_multiple_of(8) {
        out.push(0);
    }
    let cells = out.len() as u64;
    for tri in &data.cells {
        for p in tri {
            out.extend_from_slice(&p.x.to_le_bytes());
            out.extend_from_slice(&p.y.to_le_bytes());
        }
    }
    let index = out.len() as u64;
    let records_at = index + 8 * (data.cells.len() as u64 + 1);
    let mut records = Vec::new();
    let mut at = 0u64;
    put_u64(&mut out, 0);
    for set in &data.visible {
        let r = super::codec::encode_record(set, data.object_ids.len());
        at += r.len() as u64;
        records.extend_from_slice(&r);
        put_u64(&mut out, at);
    }
    out.extend_from_slice(&records);
    for (k, v) in [objects, cells, index, records_at, at]
        .into_iter()
        .enumerate()
    {
        let p = offsets_at + 8 * k;
        out[p..p + 8].copy_from_slice(&v.to_le_bytes());
    }
    let len = out.len() as u64 + 32;
    out[16..24].copy_from_slice(&len.to_le_bytes());
    let digest = Sha256::digest(&out);
    out.extend_from_slice(&digest);
    out
}
