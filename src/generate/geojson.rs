//! Writing generated buildings as an RFC 7946 FeatureCollection (through
//! [`crate::export`]): lon/lat degrees with 7 decimals (about 1 cm),
//! exterior rings counter-clockwise, holes clockwise, rings closed. A
//! vertex's text depends only on its local coordinates, so vertices shared
//! by neighbours stay identical.

use super::GeneratedBuilding;
use crate::export::{Feature, Geometry, feature_collection, json_string};
use crate::input::Frame;

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
    let features = buildings.iter().map(|b| Feature {
        id: Some(&b.id),
        properties: format!(
            "{{\"height\":{:.1},\"kind\":{}}}",
            b.height,
            json_string(b.kind.name())
        ),
        geometry: Geometry::Polygon(Geometry::rings(&b.footprint)),
    });
    feature_collection(frame, Some(decimals), features)
}
