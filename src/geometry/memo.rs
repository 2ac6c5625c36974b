//! The shape memo: results of the two costly pure steps of preparation (a
//! block level's erosion by eps, a tile's opened free space), keyed by a
//! SHA-256 of everything each result depends on, so that a run can take an
//! earlier run's result wherever those inputs are the same bits
//! (docs/DESIGN.md, "The geometry cache"). The memo only answers and
//! records; reading and writing the cache file is `crate::scale::geometry_cache`.

use std::collections::HashMap;
use std::sync::Mutex;

use sha2::{Digest, Sha256};

use crate::model::{MultiPolygon, Polygon};

/// The SHA-256 of a result's inputs.
pub type ShapeKey = [u8; 32];

/// What the keys are made from besides the inputs: the citypvs version and
/// a digest of the source of the geometry and cells stages and of the
/// locked dependencies (made by `build.rs`), so that a result of another
/// build never matches.
pub const BUILD_TAG: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    "+",
    env!("CITYPVS_GEOMETRY_SOURCE")
);

/// Builds a [`ShapeKey`]: a domain name for the step, then the step's
/// numbers and its input shape, every float by its bits.
pub struct MemoKey(Sha256);

impl MemoKey {
    /// A key of the step named `step`.
    pub fn new(step: &str) -> MemoKey {
        let mut h = Sha256::new();
        for part in ["citypvs shape memo 1", BUILD_TAG, step] {
            h.update((part.len() as u64).to_le_bytes());
            h.update(part.as_bytes());
        }
        MemoKey(h)
    }

    pub fn number(mut self, x: f64) -> MemoKey {
        self.0.update(x.to_bits().to_le_bytes());
        self
    }

    /// Every polygon, ring and vertex of `shape`, with their counts
    /// ([`hash_shape`]).
    pub fn shape(mut self, shape: &MultiPolygon) -> MemoKey {
        hash_shape(&mut self.0, shape);
        self
    }

    pub fn finish(self) -> ShapeKey {
        self.0.finalize().into()
    }
}

/// Feed `shape` to `h`: its number of polygons, then per polygon its
/// number of rings (holes + 1) and per ring its number of vertices and
/// each vertex's x and y by their bits (u64 little-endian). The object
/// fingerprints of the `.pvs` file (docs/FORMAT.md) hash shapes this way
/// too.
pub fn hash_shape(h: &mut Sha256, shape: &[Polygon]) {
    h.update((shape.len() as u64).to_le_bytes());
    for polygon in shape {
        h.update((polygon.holes.len() as u64 + 1).to_le_bytes());
        for ring in std::iter::once(&polygon.exterior).chain(&polygon.holes) {
            h.update((ring.len() as u64).to_le_bytes());
            for p in ring {
                h.update(p.x.to_bits().to_le_bytes());
                h.update(p.y.to_bits().to_le_bytes());
            }
        }
    }
}

/// Earlier results to take from, and this run's results, recorded for the
/// next run. A memo that is off neither keys nor records anything.
#[derive(Debug, Default)]
pub struct ShapeMemo {
    on: bool,
    earlier: HashMap<ShapeKey, MultiPolygon>,
    /// This run's keys, one per result asked for, with the shape where it
    /// was computed (a key taken from `earlier` keeps its shape there: no
    /// second copy).
    made: Mutex<Vec<(ShapeKey, Option<MultiPolygon>)>>,
}

/// How a memo fared: results taken from the earlier run, and computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoStats {
    pub taken: u64,
    pub computed: u64,
}

impl ShapeMemo {
    /// A memo that is off: every result is computed, nothing is kept.
    pub fn off() -> ShapeMemo {
        ShapeMemo::default()
    }

    /// A memo that takes from `earlier` and records every result.
    pub fn with(earlier: HashMap<ShapeKey, MultiPolygon>) -> ShapeMemo {
        ShapeMemo {
            on: true,
            earlier,
            ..ShapeMemo::default()
        }
    }

    /// The result keyed by `key()`: the earlier run's if it has one, else
    /// `compute()`. The same bits either way, since a key covers every
    /// input of `compute` and the build that computes it.
    pub fn shape(
        &self,
        key: impl FnOnce() -> ShapeKey,
        compute: impl FnOnce() -> MultiPolygon,
    ) -> MultiPolygon {
        if !self.on {
            return compute();
        }
        let key = key();
        let (shape, kept) = match self.earlier.get(&key) {
            Some(shape) => (shape.clone(), None),
            None => {
                let shape = compute();
                let kept = shape.clone();
                (shape, Some(kept))
            }
        };
        self.made
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((key, kept));
        shape
    }

    /// Counted from this run's record: a result taken keeps no shape of
    /// its own there.
    pub fn stats(&self) -> MemoStats {
        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        let computed = made.iter().filter(|(_, kept)| kept.is_some()).count() as u64;
        MemoStats {
            taken: made.len() as u64 - computed,
            computed,
        }
    }

    /// This run's results, for the next run.
    pub fn into_results(self) -> MemoResults {
        let mut made = self.made.into_inner().unwrap_or_else(|e| e.into_inner());
        made.sort_unstable_by_key(|e| e.0);
        made.dedup_by(|a, b| a.0 == b.0);
        MemoResults {
            earlier: self.earlier,
            made,
        }
    }
}

/// The results of one run: every key it asked for, with its shape.
pub struct MemoResults {
    earlier: HashMap<ShapeKey, MultiPolygon>,
    made: Vec<(ShapeKey, Option<MultiPolygon>)>,
}

impl MemoResults {
    pub fn len(&self) -> usize {
        self.made.len()
    }

    pub fn is_empty(&self) -> bool {
        self.made.is_empty()
    }

    /// Ascending by key, one per key.
    pub fn iter(&self) -> impl Iterator<Item = (&ShapeKey, &MultiPolygon)> {
        self.made.iter().map(|(key, shape)| {
            let shape = shape.as_ref().unwrap_or_else(|| &self.earlier[key]);
            (key, shape)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    fn square(side: f64) -> MultiPolygon {
        vec![Polygon {
            exterior: vec![
                DVec2::ZERO,
                DVec2::new(side, 0.0),
                DVec2::new(side, side),
                DVec2::new(0.0, side),
            ],
            holes: vec![],
        }]
    }

    #[test]
    fn keys_differ_by_step_number_and_every_bit_of_the_shape() {
        let key = |step, x, s: &MultiPolygon| MemoKey::new(step).number(x).shape(s).finish();
        let a = key("erode", 1.0, &square(2.0));
        assert_eq!(a, key("erode", 1.0, &square(2.0)));
        assert_ne!(a, key("tile", 1.0, &square(2.0)));
        assert_ne!(a, key("erode", 1.0 + f64::EPSILON, &square(2.0)));
        let mut nudged = square(2.0);
        nudged[0].exterior[2].x = f64::from_bits(2.0f64.to_bits() + 1);
        assert_ne!(a, key("erode", 1.0, &nudged));
        // The same vertices split into other rings are another shape.
        let mut moved = square(2.0);
        let last = moved[0].exterior.pop().unwrap();
        moved[0].holes.push(vec![last]);
        assert_ne!(a, key("erode", 1.0, &moved));
    }

    #[test]
    fn a_memo_takes_what_it_holds_and_records_every_result_once() {
        let k = |n: f64| MemoKey::new("t").number(n).finish();
        let memo = ShapeMemo::with(HashMap::from([(k(1.0), square(1.0))]));
        let got = memo.shape(|| k(1.0), || panic!("held, so not computed"));
        assert_eq!(got, square(1.0));
        assert_eq!(memo.shape(|| k(2.0), || square(2.0)), square(2.0));
        assert_eq!(memo.shape(|| k(2.0), || square(2.0)), square(2.0));
        assert_eq!(
            memo.stats(),
            MemoStats {
                taken: 1,
                computed: 2
            }
        );
        let results = memo.into_results();
        let listed: Vec<_> = results.iter().collect();
        assert_eq!(listed.len(), 2);
        assert!(listed[0].0 < listed[1].0);
        let mut expected = vec![(k(1.0), square(1.0)), (k(2.0), square(2.0))];
        expected.sort_by_key(|e| e.0);
        for ((key, shape), (k, s)) in listed.into_iter().zip(&expected) {
            assert_eq!((key, shape), (k, s));
        }

        let off = ShapeMemo::off();
        assert_eq!(
            off.shape(|| panic!("off: no key"), || square(3.0)),
            square(3.0)
        );
        assert!(off.into_results().is_empty());
    }
}
