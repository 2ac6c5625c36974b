//! The object fingerprint list of the objects section (docs/FORMAT.md,
//! "Objects", item 3): per object, a 64-bit fingerprint of its prepared
//! data, one of its occluder block, and its footprint's bounding rectangle.
//! An incremental bake (`citypvs bake --previous`) finds with it, by id and
//! without the old city, which objects changed (src/scale/rebake.rs). This
//! module owns the list's type, how it is computed from a scene, and its
//! bytes.

use glam::DVec2;
#[cfg(feature = "bake")]
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
#[cfg(feature = "bake")]
use crate::model::MultiPolygon;
use crate::model::Rect;

/// One object's entry.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "bake", derive(bincode::Encode, bincode::Decode))]
pub struct ObjectPrint {
    /// SHA-256 (first 8 bytes, little-endian) over the exact bits of the
    /// footprint, the height and the occluder flag.
    pub object: u64,
    /// SHA-256 (first 8 bytes) over the exact bits of every shrunk occluder
    /// level of the object's block, in order; 0 for an object in no block.
    pub block: u64,
    /// The footprint's bounding rectangle (outer rings): min x, min y, max x,
    /// max y in local metres.
    pub rect: [f64; 4],
}

impl ObjectPrint {
    /// The bounding rectangle.
    pub fn rect(&self) -> Rect {
        Rect {
            min: DVec2::new(self.rect[0], self.rect[1]),
            max: DVec2::new(self.rect[2], self.rect[3]),
        }
    }
}

/// Bytes of one entry in the file.
pub const PRINT_BYTES: usize = 48;

#[cfg(feature = "bake")]
fn hash_polygons(h: &mut Sha256, shape: &MultiPolygon) {
    h.update((shape.len() as u64).to_le_bytes());
    for polygon in shape {
        h.update((polygon.holes.len() as u64 + 1).to_le_bytes());
        for ring in std::iter::once(&polygon.exterior).chain(polygon.holes.iter()) {
            h.update((ring.len() as u64).to_le_bytes());
            for p in ring {
                h.update(p.x.to_bits().to_le_bytes());
                h.update(p.y.to_bits().to_le_bytes());
            }
        }
    }
}

#[cfg(feature = "bake")]
fn finish(h: Sha256) -> u64 {
    let d = h.finalize();
    u64::from_le_bytes(d[..8].try_into().expect("8 bytes"))
}

/// Every object's entry for a prepared scene, in object order. An
/// occluder naming no block of the scene (a scene put together by hand)
/// adds to no block's fingerprint.
#[cfg(feature = "bake")]
pub fn object_prints(scene: &crate::prepare::Scene) -> Vec<ObjectPrint> {
    let buildings = &scene.city.buildings;
    let mut block_hash = vec![Sha256::new(); scene.blocks.len()];
    for occ in &scene.occluders {
        let Some(h) = block_hash.get_mut(occ.block) else {
            continue;
        };
        h.update((occ.level as u64).to_le_bytes());
        h.update(occ.height.to_bits().to_le_bytes());
        hash_polygons(h, &occ.shape);
    }
    let mut of_object = vec![0u64; buildings.len()];
    for (block, h) in scene.blocks.iter().zip(block_hash) {
        let mut h = h;
        h.update((block.members.len() as u64).to_le_bytes());
        let value = finish(h).max(1);
        for &m in &block.members {
            of_object[m] = value;
        }
    }
    buildings
        .iter()
        .zip(of_object)
        .map(|(b, block)| {
            let mut h = Sha256::new();
            h.update(b.height.to_bits().to_le_bytes());
            h.update([u8::from(b.occludes)]);
            hash_polygons(&mut h, &b.footprint);
            let mut rect = Rect::EMPTY;
            for p in &b.footprint {
                for v in &p.exterior {
                    rect.include(*v);
                }
            }
            ObjectPrint {
                object: finish(h),
                block,
                rect: [rect.min.x, rect.min.y, rect.max.x, rect.max.y],
            }
        })
        .collect()
}

/// Append the list: a varint count (0 = no list, else the object count)
/// and the entries.
pub fn write_prints(out: &mut Vec<u8>, prints: &[ObjectPrint]) {
    let mut n = prints.len() as u64;
    while n >= 0x80 {
        out.push((n as u8 & 0x7f) | 0x80);
        n >>= 7;
    }
    out.push(n as u8);
    for p in prints {
        out.extend_from_slice(&p.object.to_le_bytes());
        out.extend_from_slice(&p.block.to_le_bytes());
        for v in p.rect {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
}

/// Read the list from `bytes` (what follows the spatial numbering up to the
/// end of the objects section) for `objects` objects. An empty rest is a
/// file without the list.
pub fn read_prints(bytes: &[u8], objects: usize) -> Result<Vec<ObjectPrint>> {
    if bytes.is_empty() {
        return Ok(Vec::new());
    }
    let mut at = 0;
    let mut count = 0u64;
    loop {
        let Some(&b) = bytes.get(at) else {
            return Err(Error::format(
                "objects section: the fingerprint count is cut short",
            ));
        };
        if at >= 5 {
            return Err(Error::format(
                "objects section: the fingerprint count is too long",
            ));
        }
        count |= u64::from(b & 0x7f) << (7 * at);
        at += 1;
        if b & 0x80 == 0 {
            break;
        }
    }
    if count != 0 && count != objects as u64 {
        return Err(Error::format(format!(
            "objects section: {count} object fingerprints for {objects} objects"
        )));
    }
    let rest = &bytes[at..];
    if rest.len() as u64 != count * PRINT_BYTES as u64 {
        return Err(Error::format(format!(
            "objects section: {} bytes after the fingerprint count, {count} fingerprints take {}",
            rest.len(),
            count * PRINT_BYTES as u64
        )));
    }
    let word = |k: usize| u64::from_le_bytes(rest[8 * k..8 * k + 8].try_into().expect("8 bytes"));
    let mut out = Vec::with_capacity(count as usize);
    for i in 0..count as usize {
        let w = 6 * i;
        let rect = [2, 3, 4, 5].map(|k| f64::from_bits(word(w + k)));
        if !rect.iter().all(|v| v.is_finite()) {
            return Err(Error::format(format!(
                "objects section: the fingerprint of object {i} has a non-finite rectangle"
            )));
        }
        out.push(ObjectPrint {
            object: word(w),
            block: word(w + 1),
            rect,
        });
    }
    Ok(out)
}
