//! Turning parsed features into a [`City`]: unique ids, the choice of frame
//! (lon/lat range check, origin at the buildings' bounding-box centre),
//! projection to local metres, repair, the report and `--strict`.

use std::collections::BTreeMap;

use glam::DVec2;
use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::repair::{RawFootprint, repair_footprint};
use super::{City, Frame, InputOptions, InputReport, Warning};
use crate::model::{Building, Rect};
use crate::{Error, Result};

/// A position as written in the file: lon/lat degrees or metres.
pub type RawPoint = [f64; 2];
/// A ring as written in the file, open (no repeated closing position).
pub type RawRing = Vec<RawPoint>;
/// A polygon as written in the file: the exterior ring first, then holes.
pub type RawPolygon = Vec<RawRing>;

/// How a file's coordinates are to be read.
#[derive(Clone, Debug, PartialEq)]
pub enum Coordinates {
    /// RFC 7946 lon/lat degrees.
    LonLat,
    /// Metres, in the named CRS if any.
    Metric { crs: Option<String> },
}

/// One feature that holds a building, as parsed, before projection.
#[derive(Clone, Debug)]
pub struct RawBuilding {
    /// Position of the feature in the file (0-based), for messages.
    pub index: usize,
    /// The building's id.
    pub id: String,
    /// Whether the id was written in the file (else it is the index).
    pub id_given: bool,
    /// Polygons: exterior ring first, then holes; rings open, in file coordinates.
    pub polygons: Vec<RawPolygon>,
    pub height: f64,
    pub occludes: bool,
    /// Repairs already made while parsing (e.g. rings that were not closed).
    pub notes: Vec<String>,
}

/// What a format reader hands over.
#[derive(Clone, Debug)]
pub struct Parsed {
    pub coordinates: Coordinates,
    pub buildings: Vec<RawBuilding>,
    /// Features skipped while parsing (not polygons, broken relations, ...).
    pub skipped: Vec<Warning>,
    /// Features looked at.
    pub features_read: usize,
    /// Whether the format prescribes ring winding (reversed rings are then
    /// reported as repairs).
    pub winding_matters: bool,
}

/// How a feature is named in messages: `feature "b7" (index 7)`.
pub fn feature_label(id: Option<&str>, index: usize) -> String {
    match id {
        Some(id) => format!("feature \"{id}\" (index {index})"),
        None => format!("feature #{index} (no id)"),
    }
}

/// A warning's feature name for messages: ids quoted, `#<index>` as is.
fn quoted(feature: &str) -> String {
    if feature.starts_with('#') {
        feature.to_string()
    } else {
        format!("\"{feature}\"")
    }
}

/// An error about one feature of file `name`.
pub fn feature_error(name: &str, id: Option<&str>, index: usize, what: &str) -> Error {
    Error::input(format!("{name}: {}: {what}", feature_label(id, index)))
}

impl RawBuilding {
    fn label_id(&self) -> Option<&str> {
        self.id_given.then_some(self.id.as_str())
    }

    fn warning_name(&self) -> String {
        if self.id_given {
            self.id.clone()
        } else {
            format!("#{}", self.index)
        }
    }

    fn points(&self) -> impl Iterator<Item = &RawPoint> {
        self.polygons.iter().flatten().flatten()
    }
}

/// Ids must be unique: the first clash is an error naming both features.
fn check_unique_ids(buildings: &[RawBuilding], name: &str) -> Result<()> {
    let mut seen: BTreeMap<&str, &RawBuilding> = BTreeMap::new();
    for b in buildings {
        if let Some(first) = seen.insert(&b.id, b) {
            return Err(Error::input(format!(
                "{name}: duplicate id \"{}\": {} and {} (ids must be unique)",
                b.id,
                feature_label(first.label_id(), first.index),
                feature_label(b.label_id(), b.index),
            )));
        }
    }
    Ok(())
}

/// Every coordinate must be finite, and within lon/lat range for lon/lat input.
fn check_coordinates(parsed: &Parsed, name: &str) -> Result<()> {
    for b in &parsed.buildings {
        for p in b.points() {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(feature_error(
                    name,
                    b.label_id(),
                    b.index,
                    &format!("coordinate ({}, {}) is not a finite number", p[0], p[1]),
                ));
            }
            if parsed.coordinates == Coordinates::LonLat
                && !(p[0].abs() <= 180.0 && p[1].abs() <= 90.0)
            {
                return Err(feature_error(
                    name,
                    b.label_id(),
                    b.index,
                    &format!(
                        "coordinate ({}, {}) is not lon/lat (outside [-180, 180] x [-90, 90]); if the file is in metres, use --metric",
                        p[0], p[1]
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The widest city accepted, in metres, east-west and north-south: beyond
/// it a coordinate is taken as a mistake (a typo, a wrong unit or CRS), and
/// the grids the bake builds over the city would not fit in memory.
pub const MAX_CITY_EXTENT: f64 = 100_000.0;

/// Largest projected coordinate accepted, in metres: more than any CRS
/// uses (the Earth's circumference is 40,000 km), and where f64 still
/// resolves well below a millimetre.
pub const MAX_METRIC_COORDINATE: f64 = 1e8;

/// Metric coordinates must be within [`MAX_METRIC_COORDINATE`], and the
/// buildings, once in local metres, within [`MAX_CITY_EXTENT`] of each other
/// both ways; the message names the feature and the coordinate farthest from
/// the others (the median of all vertices).
fn check_extent(parsed: &Parsed, frame: &Frame, name: &str) -> Result<()> {
    let fail = |b: &RawBuilding, what: String| feature_error(name, b.label_id(), b.index, &what);
    if let Coordinates::Metric { .. } = parsed.coordinates {
        for b in &parsed.buildings {
            if let Some(p) = b
                .points()
                .find(|p| p[0].abs().max(p[1].abs()) > MAX_METRIC_COORDINATE)
            {
                return Err(fail(
                    b,
                    format!(
                        "coordinate ({}, {}) is absurd: beyond {MAX_METRIC_COORDINATE:e} m, more than any CRS uses",
                        p[0], p[1]
                    ),
                ));
            }
        }
    }
    let to_local = frame.local_mapper();
    let mut local: Vec<(usize, RawPoint, DVec2)> = Vec::new();
    for (k, b) in parsed.buildings.iter().enumerate() {
        for p in b.points() {
            let q = to_local(p[0], p[1]);
            if !q.is_finite() {
                return Err(fail(
                    b,
                    format!(
                        "coordinate ({}, {}) cannot be projected (it is too far from the other buildings)",
                        p[0], p[1]
                    ),
                ));
            }
            local.push((k, *p, q));
        }
    }
    let bounds = Rect::of_points(local.iter().map(|(_, _, q)| q));
    if bounds.width() <= MAX_CITY_EXTENT && bounds.height() <= MAX_CITY_EXTENT {
        return Ok(());
    }
    let median = |axis: fn(&DVec2) -> f64| {
        let mut v: Vec<f64> = local.iter().map(|(_, _, q)| axis(q)).collect();
        let mid = v.len() / 2;
        *v.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let centre = DVec2::new(median(|q| q.x), median(|q| q.y));
    let far = |q: &DVec2| (q.x - centre.x).abs().max((q.y - centre.y).abs());
    let (k, p, q) = local
        .iter()
        .max_by(|a, b| far(&a.2).total_cmp(&far(&b.2)))
        .expect("a city has vertices");
    Err(fail(
        &parsed.buildings[*k],
        format!(
            "coordinate ({}, {}) lies {:.0} km from the middle of the other buildings: the city would span {:.0} km x {:.0} km, more than the {:.0} km accepted (a typo, or a wrong unit or CRS?)",
            p[0],
            p[1],
            far(q) / 1000.0,
            bounds.width() / 1000.0,
            bounds.height() / 1000.0,
            MAX_CITY_EXTENT / 1000.0
        ),
    ))
}

/// The frame centred on the buildings' bounding box.
fn choose_frame(parsed: &Parsed) -> Frame {
    let points: Vec<DVec2> = parsed
        .buildings
        .iter()
        .flat_map(|b| b.points())
        .map(|p| DVec2::new(p[0], p[1]))
        .collect();
    let bounds = Rect::of_points(&points);
    let centre = (bounds.min + bounds.max) * 0.5;
    match &parsed.coordinates {
        Coordinates::LonLat => Frame::LonLat {
            lon0: centre.x,
            lat0: centre.y,
        },
        Coordinates::Metric { crs } => Frame::Metric {
            origin: centre.round(),
            crs: crs.clone(),
        },
    }
}

/// Project a building's rings into local metres.
fn project(b: &RawBuilding, to_local: &(impl Fn(f64, f64) -> DVec2 + Sync)) -> RawFootprint {
    b.polygons
        .iter()
        .map(|rings| {
            rings
                .iter()
                .map(|ring| ring.iter().map(|p| to_local(p[0], p[1])).collect())
                .collect()
        })
        .collect()
}

/// Build the city from parsed features. `bytes` are the file's bytes (hashed).
pub fn assemble(parsed: Parsed, name: &str, bytes: &[u8], options: &InputOptions) -> Result<City> {
    if parsed.buildings.is_empty() {
        let why = match parsed.skipped.first() {
            Some(w) => format!(
                " (first skipped: feature {}: {})",
                quoted(&w.feature),
                w.message
            ),
            None => String::new(),
        };
        return Err(Error::input(format!(
            "{name}: no buildings found ({} features read, {} skipped){why}",
            parsed.features_read,
            parsed.skipped.len()
        )));
    }
    check_unique_ids(&parsed.buildings, name)?;
    check_coordinates(&parsed, name)?;
    let frame = choose_frame(&parsed);
    check_extent(&parsed, &frame, name)?;

    let repaired: Vec<_> = {
        let to_local = frame.local_mapper();
        parsed
            .buildings
            .par_iter()
            .map(|b| repair_footprint(&project(b, &to_local), parsed.winding_matters))
            .collect()
    };

    let mut report = InputReport {
        features_read: parsed.features_read,
        skipped: parsed.skipped,
        ..InputReport::default()
    };
    let mut buildings = Vec::with_capacity(repaired.len());
    for (raw, fixed) in parsed.buildings.into_iter().zip(repaired) {
        let mut notes = raw.notes.clone();
        notes.extend(fixed.notes);
        if fixed.footprint.is_empty() {
            notes.push("no usable polygon left; skipped".into());
            report.skipped.push(Warning {
                feature: raw.warning_name(),
                message: notes.join("; "),
            });
            continue;
        }
        if !notes.is_empty() {
            report.repaired.push(Warning {
                feature: raw.warning_name(),
                message: notes.join("; "),
            });
        }
        buildings.push(Building {
            id: raw.id,
            footprint: fixed.footprint,
            height: raw.height,
            occludes: raw.occludes,
        });
    }
    report.buildings = buildings.len();
    if options.strict
        && let Some(w) = report.skipped.first().or(report.repaired.first())
    {
        let more = report.skipped.len() + report.repaired.len() - 1;
        return Err(Error::input(format!(
            "{name}: feature {}: {} (--strict turns this warning into an error; {more} more)",
            quoted(&w.feature),
            w.message
        )));
    }

    if buildings.is_empty() {
        return Err(Error::input(format!(
            "{name}: no usable buildings: all {} were skipped (first: {}: {})",
            report.skipped.len(),
            report.skipped[0].feature,
            report.skipped[0].message
        )));
    }
    Ok(City {
        buildings,
        frame,
        source_hash: Sha256::digest(bytes).into(),
        report,
    })
}
