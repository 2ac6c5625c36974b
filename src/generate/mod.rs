//! Procedural test cities in the spirit of the Urbania generator: a rotated
//! street grid, blocks of wall-sharing buildings, courtyards, free-standing
//! houses, towers, and an open square or river for long views.
//!
//! OWNER: generate helper. The functions below are the agreed interface.

/// What to generate.
#[derive(Clone, Debug)]
pub struct GenerateParams {
    /// Approximate number of buildings (the generator stops at exactly this many).
    pub buildings: usize,
    pub seed: u64,
}

/// A lon/lat GeoJSON FeatureCollection (RFC 7946) of the generated city,
/// deterministic for given parameters.
pub fn generate_geojson(_params: &GenerateParams) -> String {
    todo!("generate helper")
}
