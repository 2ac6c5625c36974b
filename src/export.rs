//! Writing shapes as a GeoJSON (RFC 7946) FeatureCollection in the input's
//! frame: the one GeoJSON writer, used by `generate` (the test cities) and
//! by `prepare`'s exports (cells and shrunk occluders, for QGIS). One
//! feature per line; rings closed, in the orientation they are given;
//! coordinates with a fixed number of decimals, or in full (the shortest
//! text that reads back to the same number).

use std::fmt::Write;

use glam::DVec2;

use crate::frame::Frame;
use crate::model::Polygon;

/// A feature's geometry: rings as given (exterior first, then holes).
pub enum Geometry<'a> {
    Polygon(Vec<&'a [DVec2]>),
    MultiPolygon(Vec<Vec<&'a [DVec2]>>),
}

impl<'a> Geometry<'a> {
    /// The rings of one polygon, exterior first.
    pub fn rings(polygon: &'a Polygon) -> Vec<&'a [DVec2]> {
        std::iter::once(polygon.exterior.as_slice())
            .chain(polygon.holes.iter().map(Vec::as_slice))
            .collect()
    }
}

/// One feature: an optional id, its properties as a JSON object's text
/// (e.g. `{"cell":3}`), and its geometry.
pub struct Feature<'a> {
    pub id: Option<&'a str>,
    pub properties: String,
    pub geometry: Geometry<'a>,
}

/// The FeatureCollection of `features`, coordinates mapped from local
/// metres to the input's frame by `frame`, each with `decimals` decimals
/// (`None`: in full).
pub fn feature_collection<'a>(
    frame: &Frame,
    decimals: Option<usize>,
    features: impl IntoIterator<Item = Feature<'a>>,
) -> String {
    let mut out = String::from("{\"type\":\"FeatureCollection\",\"features\":[\n");
    let mut any = false;
    for f in features {
        if any {
            out.push_str(",\n");
        }
        any = true;
        out.push_str("{\"type\":\"Feature\",");
        if let Some(id) = f.id {
            let _ = write!(out, "\"id\":{},", json_string(id));
        }
        let _ = write!(out, "\"properties\":{},\"geometry\":", f.properties);
        match &f.geometry {
            Geometry::Polygon(rings) => {
                out.push_str("{\"type\":\"Polygon\",\"coordinates\":");
                write_polygon(&mut out, rings, frame, decimals);
            }
            Geometry::MultiPolygon(polygons) => {
                out.push_str("{\"type\":\"MultiPolygon\",\"coordinates\":[");
                for (k, rings) in polygons.iter().enumerate() {
                    if k > 0 {
                        out.push(',');
                    }
                    write_polygon(&mut out, rings, frame, decimals);
                }
                out.push(']');
            }
        }
        out.push_str("}}");
    }
    if any {
        out.push('\n');
    }
    out.push_str("]}\n");
    out
}

/// A string as JSON text, quoted and escaped.
pub fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn write_polygon(out: &mut String, rings: &[&[DVec2]], frame: &Frame, decimals: Option<usize>) {
    out.push('[');
    for (k, ring) in rings.iter().enumerate() {
        if k > 0 {
            out.push(',');
        }
        write_ring(out, ring, frame, decimals);
    }
    out.push(']');
}

/// One closed ring as a JSON array of coordinate pairs.
fn write_ring(out: &mut String, ring: &[DVec2], frame: &Frame, decimals: Option<usize>) {
    out.push('[');
    for (i, p) in ring.iter().chain(ring.first()).enumerate() {
        if i > 0 {
            out.push(',');
        }
        let (x, y) = frame.to_input(*p);
        let _ = match decimals {
            Some(d) => write!(out, "[{x:.d$},{y:.d$}]"),
            None => write!(out, "[{x:?},{y:?}]"),
        };
    }
    out.push(']');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn features_read_back_as_geojson() {
        let frame = Frame::Metric {
            origin: DVec2::new(1000.0, 2000.0),
            crs: None,
        };
        let square = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(0.0, 1.0),
        ];
        let tri = [
            DVec2::new(0.0, 0.0),
            DVec2::new(0.1, 0.0),
            DVec2::new(0.0, 1e-9),
        ];
        let text = feature_collection(
            &frame,
            None,
            [
                Feature {
                    id: Some("a \"quoted\"\n id"),
                    properties: "{\"height\":3.5}".into(),
                    geometry: Geometry::Polygon(vec![&square]),
                },
                Feature {
                    id: None,
                    properties: "{}".into(),
                    geometry: Geometry::MultiPolygon(vec![vec![&square], vec![&tri]]),
                },
            ],
        );
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let f = &v["features"];
        assert_eq!(f.as_array().unwrap().len(), 2);
        assert_eq!(f[0]["id"], "a \"quoted\"\n id");
        assert_eq!(f[0]["properties"]["height"], 3.5);
        let ring = &f[0]["geometry"]["coordinates"][0];
        assert_eq!(ring.as_array().unwrap().len(), 5, "closed");
        assert_eq!(ring[2][0], 1001.0);
        assert_eq!(ring[2][1], 2001.0);
        // In full, coordinates read back to the same numbers.
        let t = &f[1]["geometry"]["coordinates"][1][0];
        assert_eq!(t[2][1].as_f64().unwrap(), 2000.0 + 1e-9);
        assert_eq!(t[1][0].as_f64().unwrap(), 1000.0 + 0.1);
    }
}
