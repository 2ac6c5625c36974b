//! Map between the input's coordinates and local metres.
//!
//! OWNER: input helper. Interface agreed: `to_local`, `to_input`, `describe`.

use glam::DVec2;

/// How input coordinates map to local metres (x east, y north).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Frame {
    /// RFC 7946 lon/lat degrees, projected by transverse Mercator centred on
    /// (`lon0`, `lat0`), which maps to local (0, 0).
    LonLat { lon0: f64, lat0: f64 },
    /// Input already in metres; local = input - `origin`. `crs` is the CRS
    /// name given by the file, if any.
    Metric { origin: DVec2, crs: Option<String> },
}

impl Frame {
    /// Input coordinates (lon/lat degrees or metres) to local metres.
    pub fn to_local(&self, x: f64, y: f64) -> DVec2 {
        match self {
            Frame::Metric { origin, .. } => DVec2::new(x, y) - *origin,
            Frame::LonLat { .. } => todo!("transverse Mercator"),
        }
    }

    /// Local metres back to input coordinates.
    pub fn to_input(&self, p: DVec2) -> (f64, f64) {
        match self {
            Frame::Metric { origin, .. } => {
                let q = p + *origin;
                (q.x, q.y)
            }
            Frame::LonLat { .. } => todo!("inverse transverse Mercator"),
        }
    }

    /// One line describing the frame, e.g. for `inspect`.
    pub fn describe(&self) -> String {
        format!("{self:?}")
    }
}
