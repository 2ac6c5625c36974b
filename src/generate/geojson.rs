//! Writing generated buildings as an RFC 7946 FeatureCollection: lon/lat
//! degrees with 7 decimals (about 1 cm), exterior rings counter-clockwise,
//! holes clockwise, rings closed. A vertex's text depends only on its local
//! coordinates, so vertices shared by neighbours stay identical.

use std::fmt::Write;

use glam::DVec2;

use super::GeneratedBuilding;
use crate::input::Frame;

/// One closed ring as a JSON array of [lon, lat] pairs.
fn write_ring(out: &mut String, ring: &[DVec2], frame: &Frame, decimals: usize) {
    out.push('[');
    for (i, p) in ring.iter().chain(ring.first()).enumerate() {
        if i > 0 {
            out.push(',');
        }
        let (lon, lat) = frame.to_input(*p);
        let _ = write!(out, "[{lon:.decimals$},{lat:.decimals$}]");
    }
    out.push(']');
}

/// The whole FeatureCollection, one feature per line, 7 decimals.
pub fn write(buildings: &[GeneratedBuilding], frame: &Frame) -> String {
    write_with_decimals(buildings, frame, 7)
}

/// The whole FeatureCollection with `decimals` decimals per coordinate.
pub fn write_with_decimals(
    buildings: &[GeneratedBuilding],
    frame: &Frame,
    decimals: usize,
) -> String {
    let mut out = String::from("{\"type\":\"FeatureCollection\",\"features\":[\n");
    for (i, b) in buildings.iter().enumerate() {
        let _ = write!(
            out,
            "{{\"type\":\"Feature\",\"id\":\"{}\",\"properties\":{{\"height\":{:.1},\"kind\":\"{}\"}},\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[",
            b.id,
            b.height,
            b.kind.name()
        );
        write_ring(&mut out, &b.footprint.exterior, frame, decimals);
        for hole in &b.footprint.holes {
            out.push(',');
            write_ring(&mut out, hole, frame, decimals);
        }
        out.push_str("]}}");
        if i + 1 < buildings.len() {
            out.push(',');
        }
        out.push('\n');
    }
    out.push_str("]}\n");
    out
}
