//! GeoJSON (RFC 7946) FeatureCollections of Polygon / MultiPolygon
//! buildings: ids, height properties, the legacy `crs` member, and region
//! files for `--region`.

use serde_json::{Map, Value};

use super::assemble::{Coordinates, Parsed, RawBuilding, RawPoint, feature_error};
use super::height::{check_height, parse_length, parse_number};
use super::{InputOptions, METRES_PER_LEVEL, Warning};
use crate::{Error, Result};

/// A parsing problem inside one feature; becomes an error naming the feature.
type FeatureResult<T> = std::result::Result<T, String>;

/// The name of the CRS in a legacy `"crs": {"type": "name", "properties": {"name": ...}}` member.
fn legacy_crs_name(root: &Map<String, Value>) -> Option<String> {
    let crs = root.get("crs")?;
    let name = crs.get("properties")?.get("name")?.as_str()?;
    Some(name.to_string())
}

/// True for CRS names that mean lon/lat on WGS 84 (or close enough).
fn is_geographic_crs(name: &str) -> bool {
    let n = name.to_ascii_uppercase();
    n.contains("CRS84")
        || n.ends_with(":4326")
        || n.ends_with("::4326")
        || n.ends_with(":4258")
        || n.ends_with("::4258")
}

/// How the coordinates of a FeatureCollection are to be read.
fn coordinates(root: &Map<String, Value>, options: &InputOptions) -> Coordinates {
    let crs = legacy_crs_name(root);
    match crs {
        Some(name) if !is_geographic_crs(&name) => Coordinates::Metric { crs: Some(name) },
        _ if options.metric => Coordinates::Metric { crs: None },
        _ => Coordinates::LonLat,
    }
}

fn position(value: &Value) -> FeatureResult<RawPoint> {
    let pair = value
        .as_array()
        .filter(|a| a.len() >= 2)
        .ok_or_else(|| format!("position {value} is not an array of two numbers"))?;
    let coordinate = |v: &Value| {
        v.as_f64()
            .ok_or_else(|| format!("position {value} holds something that is not a number"))
    };
    Ok([coordinate(&pair[0])?, coordinate(&pair[1])?])
}

/// A ring's positions, open; notes whether it had to be closed.
fn ring(value: &Value, notes: &mut Vec<String>) -> FeatureResult<Vec<RawPoint>> {
    let positions = value
        .as_array()
        .ok_or_else(|| "a ring is not an array of positions".to_string())?;
    let mut points = positions
        .iter()
        .map(position)
        .collect::<FeatureResult<Vec<_>>>()?;
    if points.len() > 1 && points.first() == points.last() {
        points.pop();
    } else if !points.is_empty() {
        notes.push("ring was not closed; closed it".into());
    }
    Ok(points)
}

fn polygon(value: &Value, notes: &mut Vec<String>) -> FeatureResult<Vec<Vec<RawPoint>>> {
    let rings = value
        .as_array()
        .ok_or_else(|| "polygon coordinates are not an array of rings".to_string())?;
    rings.iter().map(|r| ring(r, notes)).collect()
}

/// The polygons of a Polygon or MultiPolygon geometry; `Err` for other types.
fn geometry_polygons(
    geometry: &Value,
    notes: &mut Vec<String>,
) -> FeatureResult<Option<Vec<Vec<Vec<RawPoint>>>>> {
    let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("");
    let coords = geometry.get("coordinates");
    match (kind, coords) {
        ("Polygon", Some(c)) => Ok(Some(vec![polygon(c, notes)?])),
        ("MultiPolygon", Some(c)) => {
            let polys = c
                .as_array()
                .ok_or_else(|| "MultiPolygon coordinates are not an array".to_string())?;
            Ok(Some(
                polys
                    .iter()
                    .map(|p| polygon(p, notes))
                    .collect::<FeatureResult<_>>()?,
            ))
        }
        ("Polygon" | "MultiPolygon", None) => Err(format!("{kind} has no coordinates")),
        _ => Ok(None),
    }
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

/// Lifted parts (`min_height` > 0) are objects but not occluders.
fn occludes(props: &Map<String, Value>) -> FeatureResult<bool> {
    Ok(length_property(props, "min_height")?.is_none_or(|m| m <= 0.0))
}

fn id_text(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        _ => None,
    }
}

/// Parse a GeoJSON FeatureCollection (already decoded) into buildings.
pub fn parse(root: &Value, name: &str, options: &InputOptions) -> Result<Parsed> {
    let root = root
        .as_object()
        .ok_or_else(|| Error::new(format!("{name}: GeoJSON must be a JSON object")))?;
    let kind = root.get("type").and_then(Value::as_str).unwrap_or("(none)");
    if kind != "FeatureCollection" {
        return Err(Error::new(format!(
            "{name}: expected a GeoJSON FeatureCollection, found type \"{kind}\""
        )));
    }
    let features = root
        .get("features")
        .and_then(Value::as_array)
        .ok_or_else(|| {
            Error::new(format!(
                "{name}: the FeatureCollection has no \"features\" array"
            ))
        })?;
    let empty = Map::new();
    let mut parsed = Parsed {
        coordinates: coordinates(root, options),
        buildings: Vec::new(),
        skipped: Vec::new(),
        features_read: features.len(),
        winding_matters: true,
    };
    for (index, feature) in features.iter().enumerate() {
        let props = feature
            .get("properties")
            .and_then(Value::as_object)
            .unwrap_or(&empty);
        let given_id = feature
            .get("id")
            .and_then(id_text)
            .or_else(|| props.get("id").and_then(id_text));
        let fail = |what: String| feature_error(name, given_id.as_deref(), index, &what);
        let warning_name = given_id.clone().unwrap_or_else(|| format!("#{index}"));
        let Some(geometry) = feature.get("geometry").filter(|g| !g.is_null()) else {
            parsed.skipped.push(Warning {
                feature: warning_name,
                message: "feature has no geometry; skipped".into(),
            });
            continue;
        };
        let mut notes = Vec::new();
        let Some(polygons) = geometry_polygons(geometry, &mut notes).map_err(fail)? else {
            let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("?");
            parsed.skipped.push(Warning {
                feature: warning_name,
                message: format!("geometry is a {kind}, not a Polygon or MultiPolygon; skipped"),
            });
            continue;
        };
        let height = height(props, options).map_err(fail)?;
        let occludes = occludes(props).map_err(fail)?;
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

/// The single polygon of a region file: a Polygon geometry, a Feature, or a
/// FeatureCollection with one polygon feature. Rings open, in file coordinates.
pub fn parse_region(root: &Value, name: &str) -> Result<Vec<Vec<RawPoint>>> {
    let fail = |what: &str| Error::new(format!("{name}: region: {what}"));
    let geometry = match root.get("type").and_then(Value::as_str) {
        Some("FeatureCollection") => {
            let features = root
                .get("features")
                .and_then(Value::as_array)
                .ok_or_else(|| fail("the FeatureCollection has no \"features\" array"))?;
            if features.len() != 1 {
                return Err(fail(&format!(
                    "expected exactly one polygon feature, found {} features",
                    features.len()
                )));
            }
            features[0].get("geometry")
        }
        Some("Feature") => root.get("geometry"),
        Some(_) => Some(root),
        None => None,
    }
    .ok_or_else(|| fail("expected a GeoJSON Polygon, Feature or FeatureCollection"))?;
    let mut notes = Vec::new();
    match geometry_polygons(geometry, &mut notes).map_err(|e| fail(&e))? {
        Some(mut polygons) if polygons.len() == 1 => Ok(polygons.remove(0)),
        Some(polygons) => Err(fail(&format!(
            "expected one polygon, found a MultiPolygon of {}",
            polygons.len()
        ))),
        None => Err(fail("the geometry is not a Polygon")),
    }
}
