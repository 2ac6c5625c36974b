//! GeoJSON (RFC 7946) FeatureCollections of Polygon / MultiPolygon
//! buildings: ids, height properties, the legacy `crs` member, and region
//! files for `--region`.

use serde::de::{self, Deserialize, Deserializer, SeqAccess, Visitor};
use serde_json::{Map, Value};

use super::assemble::{Coordinates, Parsed, RawBuilding, RawPoint, RawPolygon, feature_error};
use super::height::{check_height, parse_length, parse_number};
use super::{InputOptions, METRES_PER_LEVEL, Warning, detect};
use crate::{Error, Result};

/// A parsing problem inside one feature; becomes an error naming the feature.
type FeatureResult<T> = std::result::Result<T, String>;

/// Nested coordinate arrays, decoded without a heap allocation per position.
#[derive(Debug)]
pub enum Coords {
    /// A bare number (only ever seen inside a position while decoding).
    Number(f64),
    /// A position: the first two numbers of an array of numbers (a third, the
    /// elevation, is ignored).
    Position(f64, f64),
    /// An array of arrays.
    List(Vec<Coords>),
}

impl<'de> Deserialize<'de> for Coords {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        d.deserialize_any(CoordsVisitor)
    }
}

struct CoordsVisitor;

impl<'de> Visitor<'de> for CoordsVisitor {
    type Value = Coords;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("GeoJSON coordinates (nested arrays of numbers)")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Coords, E> {
        Ok(Coords::Number(v))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Coords, E> {
        Ok(Coords::Number(v as f64))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Coords, E> {
        Ok(Coords::Number(v as f64))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<Coords, A::Error> {
        let Some(first) = seq.next_element::<Coords>()? else {
            return Ok(Coords::List(Vec::new()));
        };
        if let Coords::Number(x) = first {
            let mut numbers = vec![x];
            while let Some(next) = seq.next_element::<Coords>()? {
                match next {
                    Coords::Number(v) => numbers.push(v),
                    _ => return Err(de::Error::custom("a position mixes numbers and arrays")),
                }
            }
            return match numbers[..] {
                [x, y, ..] => Ok(Coords::Position(x, y)),
                _ => Err(de::Error::custom("a position needs two numbers")),
            };
        }
        let mut items = vec![first];
        while let Some(next) = seq.next_element::<Coords>()? {
            if let Coords::Number(_) = next {
                return Err(de::Error::custom("an array mixes numbers and arrays"));
            }
            items.push(next);
        }
        Ok(Coords::List(items))
    }
}

/// A geometry object.
#[derive(serde::Deserialize)]
pub struct Geometry {
    #[serde(rename = "type")]
    kind: Option<String>,
    coordinates: Option<Coords>,
}

/// A feature.
#[derive(serde::Deserialize)]
pub struct Feature {
    id: Option<Value>,
    properties: Option<Map<String, Value>>,
    geometry: Option<Geometry>,
}

/// Any GeoJSON object this module reads: a FeatureCollection, a Feature or
/// a bare geometry (members of the other kinds stay `None`).
#[derive(serde::Deserialize)]
pub struct Document {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    features: Option<Vec<Option<Feature>>>,
    crs: Option<Value>,
    geometry: Option<Geometry>,
    coordinates: Option<Coords>,
}

/// Decode a GeoJSON document: syntax errors carry line and column.
pub fn decode(bytes: &[u8], name: &str) -> Result<Document> {
    serde_json::from_slice(bytes).map_err(|e| detect::json_error(e, bytes, name, "GeoJSON"))
}

/// The name of the CRS in a legacy `"crs": {"type": "name", "properties": {"name": ...}}` member.
fn legacy_crs_name(doc: &Document) -> Option<String> {
    let name = doc.crs.as_ref()?.get("properties")?.get("name")?.as_str()?;
    Some(name.to_string())
}

/// True for CRS names that mean lon/lat on WGS 84 (or close enough).
fn is_geographic_crs(name: &str) -> bool {
    let n = name.to_ascii_uppercase();
    n.contains("CRS84")
        || [":4326", ":4258", ":4979"]
            .iter()
            .any(|code| n.ends_with(code))
}

/// How the coordinates of a FeatureCollection are to be read.
fn coordinates(doc: &Document, options: &InputOptions) -> Coordinates {
    match legacy_crs_name(doc) {
        Some(name) if !is_geographic_crs(&name) => Coordinates::Metric { crs: Some(name) },
        _ if options.metric => Coordinates::Metric { crs: None },
        _ => Coordinates::LonLat,
    }
}

/// A ring's positions, open; notes whether it had to be closed.
fn ring(coords: &Coords, notes: &mut Vec<String>) -> FeatureResult<Vec<RawPoint>> {
    let Coords::List(positions) = coords else {
        return Err("a ring is not an array of positions".into());
    };
    let mut points = positions
        .iter()
        .map(|p| match p {
            Coords::Position(x, y) => Ok([*x, *y]),
            _ => Err("a ring holds something that is not a position".to_string()),
        })
        .collect::<FeatureResult<Vec<_>>>()?;
    if points.len() > 1 && points.first() == points.last() {
        points.pop();
    } else if !points.is_empty() {
        notes.push("ring was not closed; closed it".into());
    }
    Ok(points)
}

fn polygon(coords: &Coords, notes: &mut Vec<String>) -> FeatureResult<RawPolygon> {
    let Coords::List(rings) = coords else {
        return Err("polygon coordinates are not an array of rings".into());
    };
    rings.iter().map(|r| ring(r, notes)).collect()
}

/// The polygons of a Polygon or MultiPolygon of the given type and
/// coordinates; `None` for other types.
fn shape_polygons(
    kind: &str,
    coords: Option<&Coords>,
    notes: &mut Vec<String>,
) -> FeatureResult<Option<Vec<RawPolygon>>> {
    match (kind, coords) {
        ("Polygon", Some(c)) => Ok(Some(vec![polygon(c, notes)?])),
        ("MultiPolygon", Some(Coords::List(polys))) => Ok(Some(
            polys
                .iter()
                .map(|p| polygon(p, notes))
                .collect::<FeatureResult<_>>()?,
        )),
        ("MultiPolygon", Some(_)) => Err("MultiPolygon coordinates are not an array".into()),
        ("Polygon" | "MultiPolygon", None) => Err(format!("{kind} has no coordinates")),
        _ => Ok(None),
    }
}

fn geometry_polygons(
    geometry: &Geometry,
    notes: &mut Vec<String>,
) -> FeatureResult<Option<Vec<RawPolygon>>> {
    shape_polygons(
        geometry.kind.as_deref().unwrap_or(""),
        geometry.coordinates.as_ref(),
        notes,
    )
}

/// A height property: a number, or text like "12", "12 m", "40 ft".
fn length_property(props: &Map<String, Value>, key: &str) -> FeatureResult<Option<f64>> {
    match props.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => Ok(n.as_f64()),
        Some(Value::String(s)) => parse_length(s)
            .map(Some)
            .ok_or_else(|| format!("property {key} = \"{s}\" is not a length in metres")),
        Some(other) => Err(format!("property {key} = {other} is not a length")),
    }
}

/// A level count property: a number or a numeric string.
fn levels_property(props: &Map<String, Value>, key: &str) -> FeatureResult<Option<f64>> {
    match props.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => Ok(n.as_f64()),
        Some(Value::String(s)) => parse_number(s)
            .map(Some)
            .ok_or_else(|| format!("property {key} = \"{s}\" is not a number of levels")),
        Some(other) => Err(format!(
            "property {key} = {other} is not a number of levels"
        )),
    }
}

/// Height: `height`, else `building:levels` / `levels` x 3 m, else the default.
fn height(props: &Map<String, Value>, options: &InputOptions) -> FeatureResult<f64> {
    if let Some(h) = length_property(props, "height")? {
        return check_height(h);
    }
    for key in ["building:levels", "levels"] {
        if let Some(levels) = levels_property(props, key)? {
            return check_height(levels * METRES_PER_LEVEL)
                .map_err(|e| format!("{key} = {levels} x {METRES_PER_LEVEL} m: {e}"));
        }
    }
    check_height(options.default_height).map_err(|e| format!("--default-height: {e}"))
}

/// Lifted parts (`min_height` > 0) and open-sided structures (`building`
/// or `building:part` = `roof` / `carport`) are objects but not occluders.
fn occludes(props: &Map<String, Value>) -> FeatureResult<bool> {
    let open_sided = ["building", "building:part"].iter().any(|k| {
        props
            .get(*k)
            .and_then(Value::as_str)
            .is_some_and(super::opensided::is_open_sided)
    });
    Ok(!open_sided && length_property(props, "min_height")?.is_none_or(|m| m <= 0.0))
}

fn id_text(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        _ => None,
    }
}

/// Parse a GeoJSON FeatureCollection into buildings.
pub fn parse(doc: &Document, name: &str, options: &InputOptions) -> Result<Parsed> {
    let kind = doc.kind.as_deref().unwrap_or("(none)");
    if kind != "FeatureCollection" {
        return Err(Error::input(format!(
            "{name}: expected a GeoJSON FeatureCollection, found type \"{kind}\""
        )));
    }
    let features = doc.features.as_ref().ok_or_else(|| {
        Error::input(format!(
            "{name}: the FeatureCollection has no \"features\" array"
        ))
    })?;
    let empty = Map::new();
    let mut parsed = Parsed {
        coordinates: coordinates(doc, options),
        buildings: Vec::new(),
        skipped: Vec::new(),
        features_read: features.len(),
        winding_matters: true,
    };
    for (index, feature) in features.iter().enumerate() {
        let Some(feature) = feature else {
            parsed.skipped.push(Warning {
                feature: format!("#{index}"),
                message: "feature is null; skipped".into(),
            });
            continue;
        };
        let props = feature.properties.as_ref().unwrap_or(&empty);
        let given_id = feature
            .id
            .as_ref()
            .and_then(id_text)
            .or_else(|| props.get("id").and_then(id_text));
        let fail = |what: String| feature_error(name, given_id.as_deref(), index, &what);
        let warning_name = given_id.clone().unwrap_or_else(|| format!("#{index}"));
        let Some(geometry) = &feature.geometry else {
            parsed.skipped.push(Warning {
                feature: warning_name,
                message: "feature has no geometry; skipped".into(),
            });
            continue;
        };
        let mut notes = Vec::new();
        let Some(polygons) = geometry_polygons(geometry, &mut notes).map_err(fail)? else {
            let kind = geometry.kind.as_deref().unwrap_or("?");
            parsed.skipped.push(Warning {
                feature: warning_name,
                message: format!("geometry is a {kind}, not a Polygon or MultiPolygon; skipped"),
            });
            continue;
        };
        let height = height(props, options).map_err(fail)?;
        let occludes = occludes(props).map_err(fail)?;
        if let Some(note) = length_property(props, "min_height")
            .map_err(fail)?
            .and_then(|m| super::height::min_height_note(m, height))
        {
            notes.push(note);
        }
        parsed.buildings.push(RawBuilding {
            index,
            id: given_id.clone().unwrap_or_else(|| index.to_string()),
            id_given: given_id.is_some(),
            polygons,
            height,
            occludes,
            notes,
        });
    }
    Ok(parsed)
}

/// The type and coordinates of a geometry, if any.
fn geometry_parts(g: Option<&Geometry>) -> (&str, Option<&Coords>) {
    match g {
        Some(g) => (g.kind.as_deref().unwrap_or(""), g.coordinates.as_ref()),
        None => ("", None),
    }
}

/// The single polygon of a region file: a Polygon geometry, a Feature, or a
/// FeatureCollection with one polygon feature. Rings open, in file coordinates.
pub fn parse_region(doc: &Document, name: &str) -> Result<RawPolygon> {
    let fail = |what: &str| Error::input(format!("{name}: region: {what}"));
    let (kind, coords) = match doc.kind.as_deref() {
        Some("FeatureCollection") => {
            let features = doc
                .features
                .as_ref()
                .ok_or_else(|| fail("the FeatureCollection has no \"features\" array"))?;
            if features.len() != 1 {
                return Err(fail(&format!(
                    "expected exactly one polygon feature, found {} features",
                    features.len()
                )));
            }
            geometry_parts(features[0].as_ref().and_then(|f| f.geometry.as_ref()))
        }
        Some("Feature") => geometry_parts(doc.geometry.as_ref()),
        Some(kind) => (kind, doc.coordinates.as_ref()),
        None => ("", None),
    };
    let mut notes = Vec::new();
    match shape_polygons(kind, coords, &mut notes).map_err(|e| fail(&e))? {
        Some(mut polygons) if polygons.len() == 1 => Ok(polygons.remove(0)),
        Some(polygons) => Err(fail(&format!(
            "expected one polygon, found a MultiPolygon of {}",
            polygons.len()
        ))),
        None => Err(fail(
            "expected a GeoJSON Polygon, or a Feature or FeatureCollection holding one",
        )),
    }
}
