//! Structures with open sides (OSM `building=roof`, `building=carport`,
//! `building:part=roof`; CityJSON `BuildingInstallation`): you can see
//! under and through them, so they are PVS objects but never occluders.

/// OSM `building` / `building:part` values of structures with open sides.
pub const OPEN_SIDED_VALUES: [&str; 2] = ["roof", "carport"];

/// Whether an OSM-style `building` or `building:part` value names a
/// structure with open sides (case-insensitive, surrounding spaces ignored).
pub fn is_open_sided(value: &str) -> bool {
    let v = value.trim();
    OPEN_SIDED_VALUES.iter().any(|o| v.eq_ignore_ascii_case(o))
}

/// Whether a CityJSON city object of type `kind` with attributes
/// `attributes` has open sides: a `BuildingInstallation` (canopies,
/// balconies, outer stairs: parts attached to a building, never closed
/// walls down to the ground), or a building whose `building` attribute (as
/// in files converted from OSM) is `roof` or `carport`.
pub fn cityjson_open_sided(kind: &str, attributes: Option<&serde_json::Value>) -> bool {
    kind == "BuildingInstallation"
        || attributes
            .and_then(|a| a.get("building"))
            .and_then(serde_json::Value::as_str)
            .is_some_and(is_open_sided)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values() {
        assert!(is_open_sided("roof"));
        assert!(is_open_sided(" Carport"));
        assert!(!is_open_sided("yes"));
        assert!(!is_open_sided("roofs"));
        assert!(cityjson_open_sided("BuildingInstallation", None));
        let a = serde_json::json!({"building": "carport"});
        assert!(cityjson_open_sided("Building", Some(&a)));
        assert!(!cityjson_open_sided("Building", None));
    }
}
