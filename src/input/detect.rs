//! Telling the input formats apart: `--format` first, then the content
//! (the OSM PBF header blob, JSON and its top-level `type`), then the file
//! extension for files whose content is broken.

use serde_json::Value;

use super::Format;
use crate::{Error, Result};

/// What the first bytes say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Content {
    /// An OSM PBF file (first blob header of type "OSMHeader").
    Pbf,
    /// Text starting like a JSON object or array.
    Json,
    /// Nothing recognisable.
    Unknown,
}

/// Sniff the content of a file.
pub fn sniff(bytes: &[u8]) -> Content {
    // A PBF file starts with a 4-byte big-endian header length, then a
    // BlobHeader whose field 1 (tag 0x0a) is the string "OSMHeader".
    if bytes.len() >= 15 && bytes[4] == 0x0a && &bytes[6..15] == b"OSMHeader" {
        return Content::Pbf;
    }
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    match text.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'{') | Some(b'[') => Content::Json,
        _ => Content::Unknown,
    }
}

/// The format to read `bytes` as: `forced` if given, else from the content
/// (PBF header, JSON `type`), else from the extension of `name`.
pub fn format(bytes: &[u8], name: &str, forced: Option<Format>) -> Result<Format> {
    if let Some(format) = forced {
        return Ok(format);
    }
    match sniff(bytes) {
        Content::Pbf => Ok(Format::OsmPbf),
        Content::Json => Ok(json_format(bytes, name)?.unwrap_or(Format::Geojson)),
        Content::Unknown => from_extension(name).ok_or_else(|| {
            Error::input(format!(
                "{name}: not a GeoJSON, CityJSON or OSM PBF file (the content is not JSON and has no PBF header; use --format to force a format)"
            ))
        }),
    }
}

/// The format a file name's extension suggests.
pub fn from_extension(name: &str) -> Option<Format> {
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".pbf") {
        Some(Format::OsmPbf)
    } else if lower.ends_with(".city.json") || lower.ends_with(".cityjson") {
        Some(Format::Cityjson)
    } else if lower.ends_with(".geojson") || lower.ends_with(".json") {
        Some(Format::Geojson)
    } else {
        None
    }
}

/// The top-level `type` of a JSON object, decoded without keeping the rest.
#[derive(serde::Deserialize)]
struct TypeOnly {
    #[serde(rename = "type")]
    kind: Option<Value>,
}

/// The format a JSON document's top-level `type` names (a full, but
/// allocation-free, pass over the text; syntax errors carry line and column).
pub fn json_format(bytes: &[u8], name: &str) -> Result<Option<Format>> {
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    if text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return Err(Error::input(format!(
            "{name}: expected a JSON object at the top level"
        )));
    }
    let top: TypeOnly =
        serde_json::from_slice(text).map_err(|e| json_error(e, text, name, "JSON"))?;
    Ok(match top.kind.as_ref().and_then(Value::as_str) {
        Some("CityJSON") => Some(Format::Cityjson),
        Some("FeatureCollection" | "Feature" | "Polygon" | "MultiPolygon") => Some(Format::Geojson),
        _ => None,
    })
}

/// Decode JSON into a value tree (used for CityJSON).
pub fn decode_json(bytes: &[u8], name: &str) -> Result<Value> {
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    serde_json::from_slice(text).map_err(|e| json_error(e, text, name, "JSON"))
}

/// A one-line message for a JSON decoding error: syntax errors are "not
/// valid JSON" with line and column; structure errors are "not valid `what`".
pub fn json_error(e: serde_json::Error, bytes: &[u8], name: &str, what: &str) -> Error {
    if e.is_syntax() || e.is_eof() {
        let hint = if is_nan_or_infinity(bytes, e.line(), e.column()) {
            " (NaN and Infinity are not valid JSON numbers: coordinates and heights must be finite)"
        } else {
            ""
        };
        Error::input(format!("{name}: not valid JSON: {e}{hint}"))
    } else {
        Error::input(format!("{name}: not valid {what}: {e}"))
    }
}
/// True when the text at (line, column), both 1-based, is a NaN or Infinity token.
fn is_nan_or_infinity(bytes: &[u8], line: usize, column: usize) -> bool {
    let Some(text) = bytes.split(|&b| b == b'\n').nth(line.saturating_sub(1)) else {
        return false;
    };
    let start = column.saturating_sub(1).min(text.len());
    let rest = &text[start..];
    [&b"NaN"[..], b"Infinity", b"-Infinity", b"inf", b"nan"]
        .iter()
        .any(|t| rest.starts_with(t) || (start > 0 && text[start - 1..].starts_with(t)))
}
