//! The geometry cache file (`--geometry-cache FILE`): the shrunk levels and
//! opened tiles of an earlier preparation, by the key of their inputs
//! (`crate::geometry::memo`), so that preparing an edited city computes
//! only the levels and tiles the edit touched (docs/DESIGN.md, "The
//! geometry cache"; layout in docs/scale-out.md).
//!
//! Owns reading (every field checked, never trusted for a size) and
//! writing that file. A file that cannot be used is reported in one line
//! and treated as empty: the cache changes how long preparing takes, never
//! what it makes.

use std::collections::HashMap;
use std::path::Path;

use bincode::{Decode, Encode};
use glam::DVec2;

use super::sealed::{decode_sealed, write_sealed};
use crate::geometry::memo::{BUILD_TAG, MemoResults, ShapeKey};
use crate::model::{MultiPolygon, Polygon, Ring};
use crate::{Error, Result};

pub const CACHE_MAGIC: [u8; 8] = *b"CPVSGEOC";
pub const CACHE_VERSION: u32 = 1;

#[derive(Encode, Decode)]
struct CacheFile {
    /// [`BUILD_TAG`] of the build that wrote it.
    build: String,
    /// Ascending by key, one entry per key.
    entries: Vec<Entry>,
}

#[derive(Encode, Decode)]
struct Entry {
    key: ShapeKey,
    shape: Vec<PolygonRecord>,
}

#[derive(Encode, Decode)]
struct PolygonRecord {
    exterior: Vec<[f64; 2]>,
    holes: Vec<Vec<[f64; 2]>>,
}

/// What a cache file holds.
pub type Shapes = HashMap<ShapeKey, MultiPolygon>;

/// Read the cache at `path`: `Ok(None)` when there is no such file; an
/// error (starting with the file's name) when it is not a cache this build
/// can use.
pub fn read(path: &Path) -> Result<Option<Shapes>> {
    if !path.exists() {
        return Ok(None);
    }
    let starts_right = |b: &[u8]| b.starts_with(&CACHE_MAGIC);
    let bytes = crate::infile::read_whole(path, starts_right, "a geometry cache")?;
    decode(&bytes)
        .map(Some)
        .map_err(|e| e.context(path.display()))
}

/// Decode and check a cache file's bytes.
pub fn decode(bytes: &[u8]) -> Result<Shapes> {
    let file: CacheFile = decode_sealed(
        bytes,
        &CACHE_MAGIC,
        CACHE_VERSION,
        "a citypvs geometry cache",
    )?;
    if file.build != BUILD_TAG {
        return Err(Error::format(format!(
            "made by another build of citypvs ({}; this is {BUILD_TAG})",
            file.build
        )));
    }
    let mut shapes = Shapes::with_capacity(file.entries.len());
    for entry in file.entries {
        let shape = entry
            .shape
            .into_iter()
            .map(|p| {
                Ok(Polygon {
                    exterior: ring(p.exterior)?,
                    holes: p.holes.into_iter().map(ring).collect::<Result<_>>()?,
                })
            })
            .collect::<Result<MultiPolygon>>()?;
        if shapes.insert(entry.key, shape).is_some() {
            return Err(Error::format("invalid payload: a key twice"));
        }
    }
    Ok(shapes)
}

fn ring(points: Vec<[f64; 2]>) -> Result<Ring> {
    if points.len() < 3 || points.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::format(
            "invalid payload: a ring of fewer than 3 points or with a coordinate that is not a finite number",
        ));
    }
    Ok(points.into_iter().map(DVec2::from).collect())
}

/// What a cache file's payload is written from: the shapes by reference,
/// coded as [`CacheFile`] is decoded (bincode writes a vector as its
/// length, then its items, and an array as its items).
struct CacheOut<'a> {
    results: &'a MemoResults,
}

impl Encode for CacheOut<'_> {
    fn encode<E: bincode::enc::Encoder>(
        &self,
        e: &mut E,
    ) -> std::result::Result<(), bincode::error::EncodeError> {
        let len = |e: &mut E, n: usize| (n as u64).encode(e);
        let ring = |e: &mut E, r: &Ring| {
            len(e, r.len())?;
            r.iter().try_for_each(|v| [v.x, v.y].encode(e))
        };
        BUILD_TAG.encode(e)?;
        len(e, self.results.len())?;
        for (key, shape) in self.results.iter() {
            key.encode(e)?;
            len(e, shape.len())?;
            for p in shape {
                ring(e, &p.exterior)?;
                len(e, p.holes.len())?;
                p.holes.iter().try_for_each(|h| ring(e, h))?;
            }
        }
        Ok(())
    }
}

/// The bytes of a cache holding `results`.
pub fn encode(results: &MemoResults) -> Vec<u8> {
    let mut out = Vec::new();
    write_sealed(&mut out, &CACHE_MAGIC, CACHE_VERSION, &CacheOut { results })
        .expect("writing to a vector does not fail");
    out
}

/// Write the cache atomically (a reader never sees half a file), the
/// payload streamed, never held whole.
pub fn write(path: &Path, results: &MemoResults) -> Result<()> {
    crate::atomic::write_atomically_with(path, &mut |w| {
        let mut w = std::io::BufWriter::new(w);
        write_sealed(&mut w, &CACHE_MAGIC, CACHE_VERSION, &CacheOut { results })?;
        std::io::Write::flush(&mut w)
    })
}

/// How a preparation used its cache, for the summary.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CacheReport {
    pub file: String,
    /// Shrunk levels and opened tiles taken from the earlier run.
    pub taken: u64,
    /// Those computed (not in the cache, or no usable cache).
    pub computed: u64,
    /// Why the file there was not used, if one was there and was not.
    pub ignored: Option<String>,
    /// Entries written for the next run.
    pub written: usize,
}

/// [`crate::prepare::prepare_read`] with the cache at `path`: its shapes
/// are taken where their keys match, and the file is then rewritten with
/// this run's shapes. A file there that cannot be used is reported through
/// `warn` in one line and replaced.
pub fn prepare_cached(
    path: &Path,
    city: crate::input::City,
    read_seconds: f64,
    settings: &crate::settings::Settings,
    warn: &mut dyn FnMut(String),
) -> Result<(crate::prepare::Scene, CacheReport)> {
    let (earlier, ignored) = match read(path) {
        Ok(shapes) => (shapes.unwrap_or_default(), None),
        Err(e) => {
            warn(format!("ignoring geometry cache {e}; it will be rewritten"));
            (Shapes::new(), Some(e.to_string()))
        }
    };
    let memo = crate::geometry::memo::ShapeMemo::with(earlier);
    let scene = crate::prepare::prepare_read(city, read_seconds, settings, &memo)?;
    let stats = memo.stats();
    let results = memo.into_results();
    write(path, &results)?;
    Ok((
        scene,
        CacheReport {
            file: path.display().to_string(),
            taken: stats.taken,
            computed: stats.computed,
            ignored,
            written: results.len(),
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::memo::{MemoKey, ShapeMemo};

    fn shape(i: usize) -> MultiPolygon {
        let s = i as f64 + 0.1;
        let square = Polygon {
            exterior: vec![
                DVec2::ZERO,
                DVec2::new(s, 0.0),
                DVec2::new(s, s),
                DVec2::new(0.0, s),
            ],
            holes: vec![vec![
                DVec2::splat(0.25 * s),
                DVec2::new(0.25 * s, 0.5 * s),
                DVec2::splat(0.5 * s),
            ]],
        };
        vec![square; i % 3]
    }

    fn key(i: usize) -> ShapeKey {
        MemoKey::new("test").number(i as f64).finish()
    }

    /// A run's results, some taken from an earlier run (1 and 2), some
    /// computed (3 and 4).
    fn results() -> MemoResults {
        let memo = ShapeMemo::with((1..3).map(|i| (key(i), shape(i))).collect());
        for i in 1..5 {
            memo.shape(|| key(i), || shape(i));
        }
        memo.into_results()
    }

    /// The bytes of a file around a payload coded some other way.
    fn sealed(payload: Vec<u8>) -> Vec<u8> {
        super::super::sealed::seal(&CACHE_MAGIC, CACHE_VERSION, &payload)
    }

    #[test]
    fn a_cache_reads_back_bit_for_bit() {
        let shapes = decode(&encode(&results())).unwrap();
        assert_eq!(shapes.len(), 4);
        for i in 1..5 {
            assert_eq!(shapes[&key(i)], shape(i));
        }
        // The streamed payload is the one the decoded type codes.
        let file = CacheFile {
            build: BUILD_TAG.into(),
            entries: results()
                .iter()
                .map(|(k, s)| Entry {
                    key: *k,
                    shape: s
                        .iter()
                        .map(|p| PolygonRecord {
                            exterior: p.exterior.iter().map(|v| v.to_array()).collect(),
                            holes: p
                                .holes
                                .iter()
                                .map(|h| h.iter().map(|v| v.to_array()).collect())
                                .collect(),
                        })
                        .collect(),
                })
                .collect(),
        };
        let coded = bincode::encode_to_vec(&file, bincode::config::standard()).unwrap();
        assert!(encode(&results()) == sealed(coded));
    }

    #[test]
    fn a_damaged_cache_is_an_error_never_a_panic() {
        let bytes = encode(&results());
        for cut in [0, 7, 20, 56, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        for at in [0, 9, 30, 60, bytes.len() - 2] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x40;
            assert!(decode(&bad).is_err(), "byte {at} flipped");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
    }

    /// A payload whose checksum is right but whose contents are not:
    /// another build, a huge count, a coordinate that is not finite.
    #[test]
    fn a_well_sealed_cache_with_bad_contents_is_refused() {
        let coded = |file: &CacheFile| {
            sealed(bincode::encode_to_vec(file, bincode::config::standard()).unwrap())
        };
        let entry = |x: f64| Entry {
            key: [7; 32],
            shape: vec![PolygonRecord {
                exterior: vec![[0.0, 0.0], [1.0, 0.0], [x, 1.0]],
                holes: vec![],
            }],
        };
        let other = CacheFile {
            build: "0.0.0+0".into(),
            entries: vec![entry(1.0)],
        };
        let err = decode(&coded(&other)).unwrap_err().to_string();
        assert!(err.contains("another build"), "{err}");
        let nan = CacheFile {
            build: BUILD_TAG.into(),
            entries: vec![entry(f64::NAN)],
        };
        assert!(decode(&coded(&nan)).is_err());
        let twice = CacheFile {
            build: BUILD_TAG.into(),
            entries: vec![entry(1.0), entry(2.0)],
        };
        assert!(decode(&coded(&twice)).is_err());
        // A count of 2^40 entries in a few bytes: refused by the decode
        // budget before anything that size is allocated.
        let mut payload = bincode::encode_to_vec(BUILD_TAG, bincode::config::standard()).unwrap();
        payload.extend(bincode::encode_to_vec(1u64 << 40, bincode::config::standard()).unwrap());
        let err = decode(&sealed(payload)).unwrap_err().to_string();
        assert!(err.contains("LimitExceeded"), "{err}");
    }
}
