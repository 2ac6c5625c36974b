//! The bake's settings: every number that shapes a bake, validated and
//! defaulted once. Raw values (from the command line, a file header or a
//! test) go in as [`RawSettings`]; [`Settings::new`] checks each against the
//! conditions the method needs (docs/METHOD.md section 4) and against the
//! limits that keep the work finite, and fills the defaults. Everything
//! downstream (preparation, visibility, the file header, the judge, the
//! pictures) reads the one [`Settings`] value and checks nothing again.

use sha2::{Digest, Sha256};

use crate::error::{Error, Result};
use crate::model::Polygon;

/// Default erosion distance eps in metres.
pub const DEFAULT_EPS: f64 = 1.0;
/// Default eye height in metres (a pedestrian's eyes).
pub const DEFAULT_EYE_HEIGHT: f64 = 1.7;
/// Default margin in metres by which the footprints' bounding box is grown
/// to make the region of interest.
pub const DEFAULT_MARGIN: f64 = 50.0;
/// Default upper bound on a cell edge, in metres.
pub const DEFAULT_MAX_CELL_EDGE: f64 = 30.0;
/// Default half-size in metres of the near-field cull map around a sample.
pub const DEFAULT_NEAR_FIELD: f64 = 48.0;
/// Default minimum width in metres of a gap between footprints that counts
/// as free space (a person needs about half a metre; docs/geometry.md).
pub const DEFAULT_MIN_GAP: f64 = 0.5;

/// The largest number of pixels one near-field cull map may hold
/// (a window of 4096 x 4096 f32 heights is 64 MiB per thread).
pub const MAX_CULL_MAP_PIXELS: f64 = 4096.0 * 4096.0;
/// Upper bounds on lengths that would only make sense by mistake.
pub const MAX_EPS: f64 = 50.0;
pub const MAX_EYE_HEIGHT: f64 = 10_000.0;
pub const MAX_LENGTH: f64 = 100_000.0;

/// Settings as given, before validation. `None` means "the default".
#[derive(Clone, Debug, Default)]
pub struct RawSettings {
    pub eps: Option<f64>,
    pub pixel: Option<f64>,
    pub eye_height: Option<f64>,
    pub max_cell_edge: Option<f64>,
    pub margin: Option<f64>,
    pub near_field: Option<f64>,
    pub min_gap: Option<f64>,
    /// A region of interest in local metres, instead of the grown box.
    pub region: Option<Polygon>,
}

/// The seven numbers that shape a bake, as one plain record. Inside a
/// [`Settings`] they have been validated; in a file header
/// ([`crate::pvs::BakeInfo`]) or a shard's key they are only what was
/// stored, and go through [`Settings::new`] before use.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[cfg_attr(feature = "bake", derive(bincode::Encode, bincode::Decode))]
pub struct BakeNumbers {
    /// Erosion distance eps in metres; samples are at most 2 eps apart.
    pub eps: f64,
    /// Cull-map pixel size k in metres, with k * sqrt(2) / 2 <= eps -
    /// [`CELL_SLACK`].
    pub pixel: f64,
    /// Eye height h: cells are prisms from 0 to h.
    pub eye_height: f64,
    /// No cell edge is longer than this (metres).
    pub max_cell_edge: f64,
    /// Margin around the footprints' bounding box (ignored with a region).
    pub margin: f64,
    /// Half-size of the near-field cull map around each sample (metres).
    pub near_field: f64,
    /// Gaps between footprints narrower than this are not free space.
    pub min_gap: f64,
}

impl BakeNumbers {
    /// The names of the numbers (as their command-line flags), in the one
    /// fixed order of [`BakeNumbers::values`]: also the order in which a
    /// `.pvs` header stores them.
    pub const NAMES: [&'static str; 7] = [
        "eps",
        "eye-height",
        "pixel",
        "max-cell-edge",
        "margin",
        "near-field",
        "min-gap",
    ];

    /// The numbers in the order of [`BakeNumbers::NAMES`].
    pub fn values(&self) -> [f64; 7] {
        [
            self.eps,
            self.eye_height,
            self.pixel,
            self.max_cell_edge,
            self.margin,
            self.near_field,
            self.min_gap,
        ]
    }

    /// The numbers from their values in the order of [`BakeNumbers::NAMES`].
    pub fn from_values(v: [f64; 7]) -> BakeNumbers {
        BakeNumbers {
            eps: v[0],
            eye_height: v[1],
            pixel: v[2],
            max_cell_edge: v[3],
            margin: v[4],
            near_field: v[5],
            min_gap: v[6],
        }
    }

    /// Each number with its name: for anything that lists or compares
    /// settings.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        let v = self.values();
        std::array::from_fn(|i| (Self::NAMES[i], v[i]))
    }

    /// The numbers that differ bit for bit from `other`'s: name, this
    /// value, the other value.
    pub fn changed(&self, other: &BakeNumbers) -> Vec<(&'static str, f64, f64)> {
        self.named()
            .into_iter()
            .zip(other.named())
            .filter(|((_, a), (_, b))| a.to_bits() != b.to_bits())
            .map(|((name, a), (_, b))| (name, a, b))
            .collect()
    }
}

impl RawSettings {
    /// Raw settings with every number given, e.g. to validate a stored
    /// record or to change one number and validate again.
    pub fn given(numbers: &BakeNumbers, region: Option<Polygon>) -> RawSettings {
        RawSettings {
            eps: Some(numbers.eps),
            pixel: Some(numbers.pixel),
            eye_height: Some(numbers.eye_height),
            max_cell_edge: Some(numbers.max_cell_edge),
            margin: Some(numbers.margin),
            near_field: Some(numbers.near_field),
            min_gap: Some(numbers.min_gap),
            region,
        }
    }
}

/// Validated bake settings: the numbers (read through `Deref`, e.g.
/// `settings.eps`) and the region. Construct with [`Settings::new`] (or
/// [`Settings::default`]); nothing downstream checks them again.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    numbers: BakeNumbers,
    /// The region of interest in local metres, if one was given.
    pub region: Option<Polygon>,
}

impl std::ops::Deref for Settings {
    type Target = BakeNumbers;
    fn deref(&self) -> &BakeNumbers {
        &self.numbers
    }
}

/// How much of eps the bake keeps back for the grid of cell corners: cell
/// corners are put on the 1/256 m grid, each moving at most
/// [`crate::pvs::mesh::SNAP_DISTANCE`], and a cell's set is made valid
/// for every viewpoint within that distance of its triangle; both take
/// one snap distance of eps (docs/METHOD.md, section 4).
pub const CELL_SLACK: f64 = 2.0 * crate::pvs::mesh::SNAP_DISTANCE;

/// The part of eps left for the samples and the pixels once
/// [`CELL_SLACK`] is kept back.
pub fn usable_eps(eps: f64) -> f64 {
    eps - CELL_SLACK
}

/// The largest pixel size allowed by eps: k * sqrt(2) / 2 <= eps -
/// [`CELL_SLACK`], with a hair of margin for rounding.
pub fn default_pixel(eps: f64) -> f64 {
    usable_eps(eps) * std::f64::consts::SQRT_2 * (1.0 - 1e-9)
}

impl Default for Settings {
    fn default() -> Self {
        Settings::new(RawSettings::default()).expect("the defaults are valid")
    }
}

/// A number as a person reads it: plain when moderate, in scientific
/// notation when huge or tiny.
pub fn readable(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-3..1e7).contains(&v.abs()) {
        format!("{v:.3e}")
    } else {
        format!("{v}")
    }
}

/// A finite length no larger than `max`: positive, or zero too when
/// `zero_ok`.
fn length(name: &'static str, value: f64, max: f64, zero_ok: bool) -> Result<f64> {
    let fits = if zero_ok { value >= 0.0 } else { value > 0.0 };
    if !(fits && value.is_finite()) {
        let what = if zero_ok {
            "zero or a positive number of metres"
        } else {
            "a positive number of metres"
        };
        return Err(Error::setting(
            name,
            format!("must be {what}, got {}", readable(value)),
        ));
    }
    if value > max {
        return Err(Error::setting(
            name,
            format!("{} m is absurd (at most {max} m)", readable(value)),
        ));
    }
    Ok(value)
}

fn positive(name: &'static str, value: f64, max: f64) -> Result<f64> {
    length(name, value, max, false)
}

fn non_negative(name: &'static str, value: f64, max: f64) -> Result<f64> {
    length(name, value, max, true)
}

impl Settings {
    /// Validate raw settings and fill the defaults.
    pub fn new(raw: RawSettings) -> Result<Settings> {
        let eps = positive("eps", raw.eps.unwrap_or(DEFAULT_EPS), MAX_EPS)?;
        if eps <= 2.0 * CELL_SLACK {
            return Err(Error::setting(
                "eps",
                format!(
                    "must be more than {:.4} m, got {}: cell corners lie on a 1/256 m grid and the bake keeps \
                     {:.4} m of eps for that",
                    2.0 * CELL_SLACK,
                    readable(eps),
                    CELL_SLACK
                ),
            ));
        }
        let pixel = match raw.pixel {
            Some(p) => positive("pixel", p, MAX_EPS)?,
            None => default_pixel(eps),
        };
        if pixel * std::f64::consts::SQRT_2 / 2.0 > usable_eps(eps) {
            return Err(Error::setting(
                "pixel",
                format!(
                    "{pixel} is too large for eps {eps}: a pixel's centre must lie within eps - {CELL_SLACK:.4} m \
                     of every point of the pixel (pixel * sqrt(2) / 2 <= eps - {CELL_SLACK:.4}), or the cull map \
                     could hide a visible building; use a pixel of {:.6} or less, or a larger eps",
                    default_pixel(eps)
                ),
            ));
        }
        let eye_height = positive(
            "eye-height",
            raw.eye_height.unwrap_or(DEFAULT_EYE_HEIGHT),
            MAX_EYE_HEIGHT,
        )?;
        let max_cell_edge = positive(
            "max-cell-edge",
            raw.max_cell_edge.unwrap_or(DEFAULT_MAX_CELL_EDGE),
            MAX_LENGTH,
        )?;
        let margin = non_negative("margin", raw.margin.unwrap_or(DEFAULT_MARGIN), MAX_LENGTH)?;
        let near_field = positive(
            "near-field",
            raw.near_field.unwrap_or(DEFAULT_NEAR_FIELD),
            MAX_LENGTH,
        )?;
        if near_field < 2.0 * pixel {
            return Err(Error::setting(
                "near-field",
                format!("{near_field} m is smaller than two pixels ({pixel} m each)"),
            ));
        }
        let side = 2.0 * near_field / pixel + 2.0;
        if side * side > MAX_CULL_MAP_PIXELS {
            return Err(Error::limit(
                "pixel",
                format!(
                    "a near-field cull map of {} x {} pixels ({:.3e} pixels of {} m over {} m) is more than \
                     the limit of {:.0} pixels; use a larger --pixel or --eps, or a smaller --near-field",
                    readable(side.floor()),
                    readable(side.floor()),
                    side * side,
                    readable(pixel),
                    2.0 * near_field,
                    MAX_CULL_MAP_PIXELS
                ),
            ));
        }
        let min_gap = non_negative("min-gap", raw.min_gap.unwrap_or(DEFAULT_MIN_GAP), 100.0)?;
        Ok(Settings {
            numbers: BakeNumbers::from_values([
                eps,
                eye_height,
                pixel,
                max_cell_edge,
                margin,
                near_field,
                min_gap,
            ]),
            region: raw.region,
        })
    }

    /// The validated numbers, as one record.
    pub fn numbers(&self) -> &BakeNumbers {
        &self.numbers
    }

    /// The raw form of these settings (every value given), e.g. to change one
    /// and validate again.
    pub fn to_raw(&self) -> RawSettings {
        RawSettings::given(&self.numbers, self.region.clone())
    }

    /// Largest spacing of samples along a cell edge: 2 (eps -
    /// [`CELL_SLACK`]).
    pub fn sample_spacing(&self) -> f64 {
        2.0 * usable_eps(self.eps)
    }

    /// SHA-256 of the region's coordinates (little-endian f64 bits, exterior
    /// then holes, each ring preceded by its vertex count), or zeros when
    /// there is no region. Two bakes with the same hash used the same region.
    pub fn region_hash(&self) -> [u8; 32] {
        let Some(region) = &self.region else {
            return [0; 32];
        };
        let mut h = Sha256::new();
        for ring in std::iter::once(&region.exterior).chain(&region.holes) {
            h.update((ring.len() as u64).to_le_bytes());
            for p in ring {
                h.update(p.x.to_le_bytes());
                h.update(p.y.to_le_bytes());
            }
        }
        h.finalize().into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorKind;

    fn with(f: impl FnOnce(&mut RawSettings)) -> Result<Settings> {
        let mut raw = RawSettings::default();
        f(&mut raw);
        Settings::new(raw)
    }

    #[test]
    fn defaults_are_valid_and_pixel_follows_eps() {
        let s = Settings::default();
        assert_eq!(s.eps, DEFAULT_EPS);
        assert!(s.pixel * std::f64::consts::SQRT_2 / 2.0 <= s.eps - CELL_SLACK);
        let s = with(|r| r.eps = Some(0.5)).unwrap();
        assert!((s.pixel - (0.5 - CELL_SLACK) * std::f64::consts::SQRT_2).abs() < 1e-6);
        assert!((s.sample_spacing() - 2.0 * (0.5 - CELL_SLACK)).abs() < 1e-12);
        // eps must leave room for the grid of cell corners.
        let err = with(|r| r.eps = Some(0.011)).unwrap_err();
        assert_eq!(err.kind(), &ErrorKind::Setting("eps"));
        assert!(err.to_string().contains("1/256 m grid"), "{err}");
        // Just above the bound eps itself passes (a tiny eps then fails on
        // the near-field map's size, a different check).
        let above = with(|r| r.eps = Some(0.0111)).err();
        assert!(above.is_none_or(|e| e.kind() != &ErrorKind::Setting("eps")));
    }

    #[test]
    fn each_bad_number_is_refused_with_its_own_name() {
        type Edit = Box<dyn Fn(&mut RawSettings)>;
        let cases: Vec<(&str, Edit)> = vec![
            ("eps", Box::new(|r| r.eps = Some(0.0))),
            ("eps", Box::new(|r| r.eps = Some(f64::NAN))),
            ("eps", Box::new(|r| r.eps = Some(1e9))),
            ("pixel", Box::new(|r| r.pixel = Some(-1.0))),
            ("pixel", Box::new(|r| r.pixel = Some(2.0))),
            ("eye-height", Box::new(|r| r.eye_height = Some(1e300))),
            ("eye-height", Box::new(|r| r.eye_height = Some(0.0))),
            (
                "max-cell-edge",
                Box::new(|r| r.max_cell_edge = Some(f64::INFINITY)),
            ),
            ("margin", Box::new(|r| r.margin = Some(-1.0))),
            ("near-field", Box::new(|r| r.near_field = Some(0.1))),
            ("min-gap", Box::new(|r| r.min_gap = Some(-0.5))),
        ];
        for (name, f) in cases {
            let err = with(|r| f(r)).unwrap_err();
            assert_eq!(err.kind(), &ErrorKind::Setting(name), "{err}");
        }
    }

    #[test]
    fn a_tiny_pixel_is_refused_before_any_work_with_the_figure() {
        let err = with(|r| {
            r.eps = Some(0.015);
        })
        .unwrap_err();
        assert_eq!(err.kind(), &ErrorKind::Limit("pixel"));
        assert!(err.to_string().contains("pixels"), "{err}");
        let err = with(|r| r.pixel = Some(1e-6)).unwrap_err();
        assert_eq!(err.kind(), &ErrorKind::Limit("pixel"));
    }

    #[test]
    fn region_hash_tells_regions_apart() {
        use glam::DVec2;
        let square = |s: f64| Polygon {
            exterior: vec![
                DVec2::ZERO,
                DVec2::new(s, 0.0),
                DVec2::new(s, s),
                DVec2::new(0.0, s),
            ],
            holes: vec![],
        };
        let a = with(|r| r.region = Some(square(10.0))).unwrap();
        let b = with(|r| r.region = Some(square(11.0))).unwrap();
        assert_eq!(Settings::default().region_hash(), [0; 32]);
        assert_ne!(a.region_hash(), [0; 32]);
        assert_ne!(a.region_hash(), b.region_hash());
        assert_eq!(a.region_hash(), a.clone().region_hash());
    }
}
