//! The object fingerprint list of the objects section (docs/FORMAT.md,
//! "Objects", item 3): per object, a 64-bit fingerprint of its prepared
//! data, one of its occluder neighbourhood in its block, and its
//! footprint's bounding rectangle.
//! An incremental bake (`citypvs bake --previous`) finds with it, by id and
//! without the old city, which objects changed (src/scale/rebake.rs). This
//! module owns the list's type, how it is computed from a scene, and its
//! bytes.

use glam::DVec2;
#[cfg(feature = "bake")]
use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
#[cfg(feature = "bake")]
use crate::geometry::memo::hash_shape;
use crate::model::Rect;

use super::mesh::{MAX_GRID_NUMBER, PER_METRE, unzigzag, zigzag};
use super::rc::{Decoder, Encoder, NumberModel, PROB_INIT, Prob};

/// One object's entry.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "bake", derive(bincode::Encode, bincode::Decode))]
pub struct ObjectPrint {
    /// SHA-256 (first 8 bytes, little-endian) over the exact bits of the
    /// footprint, the height and the occluder flag.
    pub object: u64,
    /// For a member of a block of several members, SHA-256 (first 8 bytes)
    /// over its occluder neighbourhood (see [`object_prints`]); for a block
    /// of one member, `object`; 0 for an object in no block.
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

/// Bytes of one entry in memory (the file codes it in about 16).
pub const PRINT_BYTES: usize = 48;

#[cfg(feature = "bake")]
fn finish(h: Sha256) -> u64 {
    let d = h.finalize();
    u64::from_le_bytes(d[..8].try_into().expect("8 bytes"))
}

/// Opens every neighbourhood fingerprint, so that none can equal a value
/// hashed another way (an object's own fingerprint, or the whole-block
/// fingerprint files of earlier versions held).
#[cfg(feature = "bake")]
const NEIGHBOURHOOD_DOMAIN: &[u8] = b"citypvs occluder neighbourhood 2";

/// Every object's entry for a prepared scene, in object order.
///
/// The `block` entry of a member of a block of several members is its
/// occluder neighbourhood: the fingerprints, with their heights, of the
/// shrunk polygons of its block that it may hold part of (those of a level
/// no higher than the member whose rectangle meets the member's), sorted,
/// so that neither the numbering of levels nor the order of polygons
/// counts. Every point of a shrunk polygon of height H lies in the
/// footprint of a member of height at least H, whose rectangle then meets
/// the polygon's; so a polygon (and so a chain) present in only one of two
/// cities changes the entry of every member under it (docs/DESIGN.md,
/// "Incremental bakes"). An occluder naming no block of the scene (a scene
/// put together by hand) adds to no entry.
#[cfg(feature = "bake")]
pub fn object_prints(scene: &crate::prepare::Scene) -> Vec<ObjectPrint> {
    let buildings = &scene.city.buildings;
    // Per block, its shrunk polygons: height, fingerprint, rectangle.
    let mut polygons: Vec<Vec<(f64, u64, Rect)>> = vec![Vec::new(); scene.blocks.len()];
    for occ in &scene.occluders {
        let Some(list) = polygons.get_mut(occ.block) else {
            continue;
        };
        for polygon in &occ.shape {
            let mut h = Sha256::new();
            h.update(occ.height.to_bits().to_le_bytes());
            hash_shape(&mut h, std::slice::from_ref(polygon));
            list.push((occ.height, finish(h), Rect::of_points(&polygon.exterior)));
        }
    }
    let object_of = |b: &crate::model::Building| {
        let mut h = Sha256::new();
        h.update(b.height.to_bits().to_le_bytes());
        h.update([u8::from(b.occludes)]);
        hash_shape(&mut h, &b.footprint);
        finish(h)
    };
    let rects: Vec<Rect> = buildings
        .iter()
        .map(|b| crate::model::multipolygon_bounds(&b.footprint))
        .collect();
    let mut of_object = vec![0u64; buildings.len()];
    for (block, polygons) in scene.blocks.iter().zip(&polygons) {
        // A block of one member: its levels are a function of that
        // member's own data, so its fingerprint is the member's.
        if let &[m] = block.members.as_slice() {
            if let Some(b) = buildings.get(m) {
                of_object[m] = object_of(b).max(1);
            }
            continue;
        }
        for &m in &block.members {
            let (Some(b), Some(rect)) = (buildings.get(m), rects.get(m)) else {
                continue;
            };
            let mut under: Vec<(u64, u64)> = polygons
                .iter()
                .filter(|(height, _, r)| *height <= b.height && r.intersects(rect))
                .map(|&(height, print, _)| (height.to_bits(), print))
                .collect();
            under.sort_unstable();
            let mut h = Sha256::new();
            h.update(NEIGHBOURHOOD_DOMAIN);
            h.update((under.len() as u64).to_le_bytes());
            for (height, print) in under {
                h.update(height.to_le_bytes());
                h.update(print.to_le_bytes());
            }
            of_object[m] = finish(h).max(1);
        }
    }
    buildings
        .iter()
        .zip(of_object)
        .zip(rects)
        .map(|((b, block), rect)| ObjectPrint {
            object: object_of(b),
            block,
            rect: [rect.min.x, rect.min.y, rect.max.x, rect.max.y],
        })
        .collect()
}

/// Grid numbers (1/256 m) of a rectangle, rounded outwards.
fn rect_numbers(rect: &[f64; 4]) -> [i64; 4] {
    let g = |v: f64, up: bool| {
        let s = v * PER_METRE;
        (if up { s.ceil() } else { s.floor() }) as i64
    };
    [
        g(rect[0], false),
        g(rect[1], false),
        g(rect[2], true),
        g(rect[3], true),
    ]
}

/// Whether the file can store `rect`: finite, min <= max on both axes, and
/// every grid number within 2^52 (docs/FORMAT.md, "Objects").
pub fn rect_storable(rect: &[f64; 4]) -> bool {
    rect.iter().all(|v| v.is_finite())
        && rect[0] <= rect[2]
        && rect[1] <= rect[3]
        && rect_numbers(rect)
            .iter()
            .all(|g| g.unsigned_abs() <= MAX_GRID_NUMBER as u64)
}

/// The rectangle a file stores for `rect`: the footprint's rectangle
/// rounded outwards to the 1/256 m grid (so it still holds the footprint).
pub fn stored_rect(rect: &[f64; 4]) -> [f64; 4] {
    rect_numbers(rect).map(|v| v as f64 / PER_METRE)
}

/// The models of the list's stream (docs/FORMAT.md, "Objects").
struct PrintModels {
    kind: [Prob; 4],
    corner: [NumberModel; 2],
    size: [NumberModel; 2],
}

impl PrintModels {
    fn new() -> Self {
        PrintModels {
            kind: [PROB_INIT; 4],
            corner: [NumberModel::default(), NumberModel::default()],
            size: [NumberModel::default(), NumberModel::default()],
        }
    }
}

/// Append the list: a varint count (0 = no list, else the object count)
/// and, for a list, one range-coded stream of the entries in spatial rank
/// order (`input_of_rank`), running to the end of the section. Each
/// rectangle is stored rounded outwards to the 1/256 m grid.
pub fn write_prints(out: &mut Vec<u8>, prints: &[ObjectPrint], input_of_rank: &[u32]) {
    super::codec::write_leb128(out, prints.len() as u64);
    if prints.is_empty() {
        return;
    }
    let mut rc = Encoder::new();
    let mut m = PrintModels::new();
    let mut previous_block = 0u64;
    let mut previous_corner = [0i64; 2];
    for &i in input_of_rank {
        let p = &prints[i as usize];
        rc.plain(p.object, 64);
        let kind = if p.block == 0 {
            0
        } else if p.block == p.object {
            1
        } else if p.block == previous_block {
            2
        } else {
            3
        };
        rc.tree(&mut m.kind, 2, kind);
        if kind == 3 {
            rc.plain(p.block, 64);
        }
        previous_block = p.block;
        let r = rect_numbers(&p.rect);
        for k in 0..2 {
            rc.number(&mut m.corner[k], zigzag(r[k] - previous_corner[k]));
            rc.number(&mut m.size[k], (r[k + 2] - r[k]) as u64);
            previous_corner[k] = r[k];
        }
    }
    out.extend_from_slice(&rc.finish());
}

/// Read the list from `bytes` (what follows the spatial numbering up to the
/// end of the objects section) for `objects` objects numbered by
/// `input_of_rank`. An empty rest is a file without the list.
pub fn read_prints(
    bytes: &[u8],
    objects: usize,
    input_of_rank: &[u32],
) -> Result<Vec<ObjectPrint>> {
    if bytes.is_empty() {
        return Ok(Vec::new());
    }
    let mut at = 0;
    let count = super::blocks::read_varint(bytes, &mut at)
        .map_err(|e| Error::format(format!("objects section: the fingerprint count: {e}")))?;
    if count == 0 {
        if at != bytes.len() {
            return Err(Error::format(format!(
                "objects section: {} bytes after a fingerprint count of 0",
                bytes.len() - at
            )));
        }
        return Ok(Vec::new());
    }
    if count != objects as u64 {
        return Err(Error::format(format!(
            "objects section: {count} object fingerprints for {objects} objects"
        )));
    }
    let past = |_| Error::format("objects section: the fingerprints' coding runs past its end");
    let mut rc =
        Decoder::new(&bytes[at..]).map_err(|e| Error::format(format!("objects section: {e}")))?;
    let mut m = PrintModels::new();
    let mut out = vec![
        ObjectPrint {
            object: 0,
            block: 0,
            rect: [0.0; 4],
        };
        objects
    ];
    let mut previous_block = 0u64;
    let mut previous_corner = [0i64; 2];
    for (r, &i) in input_of_rank.iter().enumerate() {
        let object = rc.plain(64).map_err(past)?;
        let block = match rc.tree(&mut m.kind, 2).map_err(past)? {
            0 => 0,
            1 => object,
            2 => previous_block,
            _ => rc.plain(64).map_err(past)?,
        };
        previous_block = block;
        let mut rect = [0.0; 4];
        for k in 0..2 {
            let bad = || {
                Error::format(format!(
                    "objects section: the rectangle of rank {r} is out of range"
                ))
            };
            let z = rc.number(&mut m.corner[k]).map_err(past)?.ok_or_else(bad)?;
            let lo = previous_corner[k]
                .checked_add(unzigzag(z))
                .filter(|v| v.abs() <= MAX_GRID_NUMBER)
                .ok_or_else(bad)?;
            let size = rc.number(&mut m.size[k]).map_err(past)?.ok_or_else(bad)?;
            let hi = i64::try_from(size)
                .ok()
                .and_then(|s| lo.checked_add(s))
                .filter(|v| v.abs() <= MAX_GRID_NUMBER)
                .ok_or_else(bad)?;
            previous_corner[k] = lo;
            rect[k] = lo as f64 / PER_METRE;
            rect[k + 2] = hi as f64 / PER_METRE;
        }
        out[i as usize] = ObjectPrint {
            object,
            block,
            rect,
        };
    }
    let end = at + rc.pos();
    if end != bytes.len() {
        return Err(Error::format(format!(
            "objects section: {} bytes after the fingerprints' coding",
            bytes.len() - end
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_list_round_trips_with_rectangles_rounded_outwards(
            entries in proptest::collection::vec(
                (any::<u64>(), 0u8..4, -5e5f64..5e5, -5e5f64..5e5, 0f64..300.0, 0f64..300.0),
                1..60,
            ),
            seed in any::<u64>(),
        ) {
            let mut prints: Vec<ObjectPrint> = Vec::new();
            for (k, &(object, kind, x, y, w, h)) in entries.iter().enumerate() {
                let block = match kind {
                    0 => 0,
                    1 => object,
                    2 => prints.last().map_or(7, |p| p.block),
                    _ => object ^ (k as u64 + 1),
                };
                prints.push(ObjectPrint { object, block, rect: [x, y, x + w, y + h] });
            }
            let n = prints.len();
            // Some permutation as the spatial numbering.
            let mut input_of_rank: Vec<u32> = (0..n as u32).collect();
            input_of_rank.sort_by_key(|&i| (u64::from(i) ^ seed).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let mut bytes = Vec::new();
            write_prints(&mut bytes, &prints, &input_of_rank);
            let back = read_prints(&bytes, n, &input_of_rank).unwrap();
            for (p, q) in prints.iter().zip(&back) {
                prop_assert_eq!(p.object, q.object);
                prop_assert_eq!(p.block, q.block);
                prop_assert_eq!(q.rect, stored_rect(&p.rect));
                // Outwards by less than one grid step.
                prop_assert!(q.rect[0] <= p.rect[0] && p.rect[0] - q.rect[0] < 1.0 / 256.0);
                prop_assert!(q.rect[1] <= p.rect[1] && p.rect[1] - q.rect[1] < 1.0 / 256.0);
                prop_assert!(q.rect[2] >= p.rect[2] && q.rect[2] - p.rect[2] < 1.0 / 256.0);
                prop_assert!(q.rect[3] >= p.rect[3] && q.rect[3] - p.rect[3] < 1.0 / 256.0);
            }
            // Cut short or with a byte more: refused, never a panic.
            for cut in [bytes.len() - 1, bytes.len() / 2, 1] {
                prop_assert!(read_prints(&bytes[..cut], n, &input_of_rank).is_err());
            }
            let mut longer = bytes.clone();
            longer.push(1);
            prop_assert!(read_prints(&longer, n, &input_of_rank).is_err());
        }
    }
}
