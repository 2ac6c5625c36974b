//! CityJSON 1.0, 1.1 and 2.0 files (versions "1.0", "1.1", "2.0", each
//! with an optional ".N" patch number): `Building` and `BuildingPart` city
//! objects. The footprint is the GroundSurface semantic surface(s) of the
//! object's highest-LoD geometry, else its surfaces lying flat at the lowest
//! height; the height is the highest vertex minus the ground, the lowest
//! vertex of the building and all its parts; parts lifted off that ground
//! do not occlude. The file's
//! `transform` is applied; coordinates are metres in the CRS named by
//! `metadata.referenceSystem`.

use std::collections::BTreeMap;

use serde_json::{Map, Value};

use super::assemble::{Coordinates, Parsed, RawBuilding, RawPoint, RawPolygon, feature_error};
use super::height::check_height;
use super::{InputOptions, Warning};
use crate::{Error, Result};

/// Surfaces within this height (metres) of the lowest vertex lie on the ground.
const GROUND_TOLERANCE: f64 = 0.01;

/// A part whose lowest vertex is more than this (metres) above its
/// building's ground is lifted: an object, but not an occluder.
const LIFT_TOLERANCE: f64 = 0.1;

/// A surface: rings of 3D points, the first the outer ring.
type Surface = Vec<Vec<[f64; 3]>>;

/// The versions read: CityJSON 1.0, 1.1 and 2.0 (1.0 has the same
/// building model; only its `transform` is optional).
const VERSIONS: [&str; 3] = ["1.0", "1.1", "2.0"];

/// The file's version, one of [`VERSIONS`], from `"1.1"` or `"1.1.2"`.
fn version(root: &Map<String, Value>, name: &str) -> Result<&'static str> {
    let unsupported = |shown: String| {
        Error::input(format!(
            "{name}: CityJSON version {shown} is not supported (1.0, 1.1 and 2.0 are, written as a string such as \"2.0\")"
        ))
    };
    let text = match root.get("version") {
        None => return Err(unsupported("(none: the file has no \"version\")".into())),
        Some(Value::String(s)) => s.as_str(),
        Some(Value::Number(n)) => {
            return Err(Error::input(format!(
                "{name}: CityJSON version is the number {n}; it must be a string (\"version\": \"{n}\")"
            )));
        }
        Some(other) => return Err(unsupported(other.to_string())),
    };
    let (major_minor, patch) = match text.match_indices('.').nth(1) {
        Some((i, _)) => (&text[..i], Some(&text[i + 1..])),
        None => (text, None),
    };
    let patch_ok = patch.is_none_or(|p| !p.is_empty() && p.bytes().all(|c| c.is_ascii_digit()));
    match VERSIONS.iter().find(|v| **v == major_minor) {
        Some(v) if patch_ok => Ok(v),
        _ => Err(unsupported(format!("\"{text}\""))),
    }
}

/// The file's vertices with the transform applied (CityJSON 1.1 and 2.0
/// require a transform; 1.0 files may have plain coordinates).
fn vertices(root: &Map<String, Value>, name: &str, version: &str) -> Result<Vec<[f64; 3]>> {
    let (scale, translate) = match root.get("transform") {
        Some(t) => {
            let triple = |key: &str| -> Result<[f64; 3]> {
                let v = t
                    .get(key)
                    .and_then(Value::as_array)
                    .filter(|a| a.len() == 3);
                let v = v.ok_or_else(|| {
                    Error::input(format!(
                        "{name}: transform.{key} is not an array of 3 numbers"
                    ))
                })?;
                let mut out = [0.0; 3];
                for (o, x) in out.iter_mut().zip(v) {
                    *o = x.as_f64().ok_or_else(|| {
                        Error::input(format!("{name}: transform.{key} holds a non-number"))
                    })?;
                }
                Ok(out)
            };
            (triple("scale")?, triple("translate")?)
        }
        None if version == "1.0" => ([1.0; 3], [0.0; 3]),
        None => {
            return Err(Error::input(format!(
                "{name}: CityJSON {version} file has no \"transform\" (it is required: vertices are integers scaled by transform.scale)"
            )));
        }
    };
    let list = root
        .get("vertices")
        .and_then(Value::as_array)
        .ok_or_else(|| Error::input(format!("{name}: CityJSON has no \"vertices\" array")))?;
    list.iter()
        .enumerate()
        .map(|(i, v)| {
            let xyz = v
                .as_array()
                .filter(|a| a.len() == 3)
                .and_then(|a| Some([a[0].as_f64()?, a[1].as_f64()?, a[2].as_f64()?]))
                .ok_or_else(|| {
                    Error::input(format!("{name}: vertex {i} is not an array of 3 numbers"))
                })?;
            Ok([
                xyz[0] * scale[0] + translate[0],
                xyz[1] * scale[1] + translate[1],
                xyz[2] * scale[2] + translate[2],
            ])
        })
        .collect()
}

/// The LoD of a geometry as a number ("2.2" -> 2.2); unknown -> 0.
fn lod(geometry: &Value) -> f64 {
    match geometry.get("lod") {
        Some(Value::String(s)) => s.parse().unwrap_or(0.0),
        Some(Value::Number(n)) => n.as_f64().unwrap_or(0.0),
        _ => 0.0,
    }
}

/// Every surface of a geometry with its semantic type (if any).
fn surfaces(
    geometry: &Value,
    verts: &[[f64; 3]],
) -> std::result::Result<Vec<(Surface, Option<String>)>, String> {
    let kind = geometry.get("type").and_then(Value::as_str).unwrap_or("");
    // Depth of nesting above the surface level: MultiSurface 0, Solid 1, MultiSolid 2.
    let depth = match kind {
        "MultiSurface" | "CompositeSurface" => 0,
        "Solid" => 1,
        "MultiSolid" | "CompositeSolid" => 2,
        other => return Err(format!("geometry type \"{other}\" has no surfaces")),
    };
    let boundaries = geometry
        .get("boundaries")
        .ok_or("geometry has no boundaries")?;
    let semantic_types: Vec<Option<String>> = geometry
        .get("semantics")
        .and_then(|s| s.get("surfaces"))
        .and_then(Value::as_array)
        .map(|list| {
            list.iter()
                .map(|s| s.get("type").and_then(Value::as_str).map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    let values = geometry.get("semantics").and_then(|s| s.get("values"));
    let mut out = Vec::new();
    collect_surfaces(boundaries, values, depth, verts, &semantic_types, &mut out)?;
    Ok(out)
}

fn collect_surfaces(
    boundaries: &Value,
    values: Option<&Value>,
    depth: usize,
    verts: &[[f64; 3]],
    semantic_types: &[Option<String>],
    out: &mut Vec<(Surface, Option<String>)>,
) -> std::result::Result<(), String> {
    let list = boundaries.as_array().ok_or("boundaries are not arrays")?;
    for (i, item) in list.iter().enumerate() {
        let value = values.and_then(|v| v.get(i));
        if depth > 0 {
            collect_surfaces(item, value, depth - 1, verts, semantic_types, out)?;
            continue;
        }
        let rings = item
            .as_array()
            .ok_or("a surface is not an array of rings")?;
        let surface = rings
            .iter()
            .map(|ring| {
                ring.as_array()
                    .ok_or("a ring is not an array of vertex indices")?
                    .iter()
                    .map(|index| {
                        index
                            .as_u64()
                            .and_then(|k| verts.get(k as usize))
                            .copied()
                            .ok_or_else(|| format!("vertex index {index} is out of range"))
                    })
                    .collect::<std::result::Result<Vec<_>, String>>()
            })
            .collect::<std::result::Result<Surface, String>>()?;
        let semantic = value
            .and_then(Value::as_u64)
            .and_then(|k| semantic_types.get(k as usize).cloned().flatten());
        out.push((surface, semantic));
    }
    Ok(())
}

/// One object's footprint and the heights of its lowest and highest vertex.
struct Extent {
    polygons: Vec<RawPolygon>,
    low: f64,
    high: f64,
}

/// Footprint polygons (rings open, 2D) and vertical extent of one geometry.
fn footprint_and_extent(
    geometry: &Value,
    verts: &[[f64; 3]],
) -> std::result::Result<Extent, String> {
    let surfaces = surfaces(geometry, verts)?;
    let zs = surfaces
        .iter()
        .flat_map(|(s, _)| s.iter().flatten().map(|p| p[2]));
    let (low, high) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), z| {
        (l.min(z), h.max(z))
    });
    if !low.is_finite() {
        return Err("the geometry has no vertices".into());
    }
    let ground: Vec<&Surface> = surfaces
        .iter()
        .filter(|(_, t)| t.as_deref() == Some("GroundSurface"))
        .map(|(s, _)| s)
        .collect();
    let ground = if ground.is_empty() {
        surfaces
            .iter()
            .map(|(s, _)| s)
            .filter(|s| s.iter().flatten().all(|p| p[2] <= low + GROUND_TOLERANCE))
            .collect()
    } else {
        ground
    };
    if ground.is_empty() {
        return Err("no GroundSurface and no surface lying at the lowest height".into());
    }
    let polygons = ground
        .iter()
        .map(|surface| {
            surface
                .iter()
                .map(|ring| {
                    let mut points: Vec<RawPoint> = ring.iter().map(|p| [p[0], p[1]]).collect();
                    if points.len() > 1 && points.first() == points.last() {
                        points.pop();
                    }
                    points
                })
                .collect()
        })
        .collect();
    Ok(Extent {
        polygons,
        low,
        high,
    })
}

/// The first of an object's `parents` that is in the file, if any.
fn parent_of<'a>(objects: &'a Map<String, Value>, id: &str) -> Option<&'a str> {
    objects
        .get(id)
        .and_then(|o| o.get("parents"))
        .and_then(Value::as_array)
        .and_then(|p| p.first())
        .and_then(Value::as_str)
        .filter(|p| objects.contains_key(*p))
}

/// The top-most ancestors of objects (following the first of their
/// `parents`), remembered so that every chain is walked once.
#[derive(Default)]
struct FamilyRoots<'a> {
    known: BTreeMap<&'a str, &'a str>,
}

impl<'a> FamilyRoots<'a> {
    /// The root of `id`'s family, or the ids of a cycle of parents.
    fn of(
        &mut self,
        objects: &'a Map<String, Value>,
        id: &'a str,
    ) -> std::result::Result<&'a str, String> {
        let mut chain: Vec<&'a str> = Vec::new();
        let mut on_chain: std::collections::BTreeSet<&'a str> = Default::default();
        let mut current = id;
        let root = loop {
            if let Some(root) = self.known.get(current) {
                break *root;
            }
            if !on_chain.insert(current) {
                let start = chain.iter().position(|c| *c == current).unwrap_or(0);
                let cycle: Vec<String> = chain[start..]
                    .iter()
                    .chain(std::iter::once(&current))
                    .map(|c| format!("\"{c}\""))
                    .collect();
                return Err(format!(
                    "its parents form a cycle: {} (an object cannot be its own ancestor)",
                    cycle.join(" -> ")
                ));
            }
            chain.push(current);
            match parent_of(objects, current) {
                Some(p) => current = p,
                None => break current,
            }
        };
        for c in chain {
            self.known.insert(c, root);
        }
        Ok(root)
    }
}

/// Parse a CityJSON document into buildings.
pub fn parse(root: &Value, name: &str, options: &InputOptions) -> Result<Parsed> {
    if options.metric {
        return Err(Error::input(format!(
            "{name}: --metric does not apply to CityJSON files (they are always in metres)"
        )));
    }
    if options.default_height_given {
        return Err(Error::input(format!(
            "{name}: --default-height does not apply to CityJSON files (heights come from the geometry)"
        )));
    }
    let root = root
        .as_object()
        .ok_or_else(|| Error::input(format!("{name}: CityJSON must be a JSON object")))?;
    let version = version(root, name)?;
    let verts = vertices(root, name, version)?;
    let objects = root
        .get("CityObjects")
        .and_then(Value::as_object)
        .ok_or_else(|| Error::input(format!("{name}: CityJSON has no \"CityObjects\" object")))?;
    let crs = root
        .get("metadata")
        .and_then(|m| m.get("referenceSystem"))
        .and_then(Value::as_str)
        .map(str::to_string);
    let mut parsed = Parsed {
        coordinates: Coordinates::Metric { crs },
        buildings: Vec::new(),
        skipped: Vec::new(),
        features_read: 0,
        winding_matters: false,
    };
    let mut extents = Vec::new();
    let mut roots = FamilyRoots::default();
    for (index, (id, object)) in objects.iter().enumerate() {
        let kind = object.get("type").and_then(Value::as_str).unwrap_or("");
        if kind != "Building" && kind != "BuildingPart" && kind != "BuildingInstallation" {
            continue;
        }
        let open_sided = super::opensided::cityjson_open_sided(kind, object.get("attributes"));
        parsed.features_read += 1;
        let geometries = object.get("geometry").and_then(Value::as_array);
        let best = geometries
            .into_iter()
            .flatten()
            .filter(|g| g.get("type").and_then(Value::as_str) != Some("GeometryInstance"))
            .max_by(|a, b| lod(a).total_cmp(&lod(b)));
        let Some(geometry) = best else {
            let has_parts = object
                .get("children")
                .and_then(Value::as_array)
                .is_some_and(|c| !c.is_empty());
            if !has_parts {
                parsed.skipped.push(Warning {
                    feature: id.clone(),
                    message: format!("{kind} has no geometry; skipped"),
                });
            }
            continue;
        };
        let extent = footprint_and_extent(geometry, &verts)
            .map_err(|e| feature_error(name, Some(id), index, &e))?;
        let root = roots
            .of(objects, id)
            .map_err(|e| feature_error(name, Some(id), index, &e))?;
        extents.push((index, id, root, extent, open_sided));
    }
    // A building and its parts stand on one ground: the lowest vertex of all of them.
    let mut ground: BTreeMap<&str, f64> = BTreeMap::new();
    for (_, _, root, extent, _) in &extents {
        let g = ground.entry(root).or_insert(f64::INFINITY);
        *g = g.min(extent.low);
    }
    for (index, id, root, extent, open_sided) in extents {
        let ground = ground[root];
        let height = check_height(extent.high - ground)
            .map_err(|e| feature_error(name, Some(id), index, &e))?;
        parsed.buildings.push(RawBuilding {
            index,
            id: id.clone(),
            id_given: true,
            polygons: extent.polygons,
            height,
            occludes: !open_sided && extent.low <= ground + LIFT_TOLERANCE,
            notes: Vec::new(),
        });
    }
    Ok(parsed)
}
