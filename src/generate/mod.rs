//! Procedural test cities in the spirit of the Urbania generator: a street
//! grid rotated 15 degrees, blocks of wall-sharing buildings, courtyards,
//! free-standing houses, towers, an open square and a river-like strip for
//! long views.
//!
//! The city is laid out in local metres around (0, 0) ([`layout`]), its
//! blocks are filled with buildings ([`buildings`]), and it is written as
//! lon/lat GeoJSON around a fixed origin ([`geojson`]). Everything is drawn
//! from ChaCha8 streams seeded by the seed, so the output is the same on
//! every platform.

pub mod buildings;
pub mod geojson;
pub mod layout;
pub mod oldtown;

use glam::DVec2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::model::Polygon;

/// What to generate.
#[derive(Clone, Debug)]
pub struct GenerateParams {
    /// Approximate number of buildings (the generator stops at exactly this many).
    pub buildings: usize,
    pub seed: u64,
}

/// The look of a generated city.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Style {
    /// Streets, row blocks with exactly shared walls, courtyards, houses,
    /// towers, a square and a river.
    #[default]
    Default,
    /// Perimeter blocks of separate wall-sharing buildings drawn with the
    /// small misalignments of real map data (see [`oldtown`]).
    OldTown,
}

/// The city in the given style.
pub fn generate_styled(params: &GenerateParams, style: Style) -> GeneratedCity {
    match style {
        Style::Default => generate_city(params),
        Style::OldTown => oldtown::generate_old_town(params),
    }
}

/// The GeoJSON text of the city in the given style: 7 decimals for the
/// default style (about 1 cm), 9 (about 0.1 mm) for the old town, whose
/// millimetre misalignments must survive.
pub fn generate_geojson_styled(params: &GenerateParams, style: Style) -> String {
    let city = generate_styled(params, style);
    geojson::write_with_decimals(&city.buildings, &frame(), decimals(style))
}

/// Decimals of the lon/lat coordinates written for a style.
pub fn decimals(style: Style) -> usize {
    match style {
        Style::Default => 7,
        Style::OldTown => 9,
    }
}

/// The fixed geographic origin of generated cities (local (0, 0)): lon, lat in degrees.
pub const ORIGIN_LON: f64 = 24.9384;
pub const ORIGIN_LAT: f64 = 60.1699;
/// The street grid's rotation from east, degrees counter-clockwise.
pub const GRID_ROTATION_DEG: f64 = 15.0;
/// Target density: buildings per square kilometre of city.
pub const BUILDINGS_PER_KM2: f64 = 1000.0;

/// What a generated building is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// One of a row of wall-sharing buildings along a street.
    Row,
    /// A ring building around a courtyard (a polygon with a hole).
    Courtyard,
    /// A small free-standing house.
    House,
    /// A free-standing tower, 40-120 m high.
    Tower,
}

impl Kind {
    /// The name written to the `kind` property.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Row => "row",
            Kind::Courtyard => "courtyard",
            Kind::House => "house",
            Kind::Tower => "tower",
        }
    }
}

/// One generated building in local metres (x east, y north, origin at
/// [`ORIGIN_LON`], [`ORIGIN_LAT`]).
#[derive(Clone, Debug, PartialEq)]
pub struct GeneratedBuilding {
    /// `"b<index>"`.
    pub id: String,
    pub kind: Kind,
    /// Metres.
    pub height: f64,
    /// CCW exterior, CW holes, rings not closed.
    pub footprint: Polygon,
}

/// The geographic frame the city is written in.
pub fn frame() -> crate::input::Frame {
    crate::input::Frame::LonLat {
        lon0: ORIGIN_LON,
        lat0: ORIGIN_LAT,
    }
}

/// The random stream for the street plan (0) or one block (1 + row, column).
fn stream(seed: u64, id: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id);
    rng
}

/// Rotate a grid-frame point into local metres.
fn to_local(u: f64, v: f64) -> DVec2 {
    let (s, c) = GRID_ROTATION_DEG.to_radians().sin_cos();
    DVec2::new(u * c - v * s, u * s + v * c)
}

/// The corners of a grid rectangle in local metres, counter-clockwise.
fn ring_ccw(r: &layout::GridRect) -> Vec<DVec2> {
    vec![
        to_local(r.u0, r.v0),
        to_local(r.u1, r.v0),
        to_local(r.u1, r.v1),
        to_local(r.u0, r.v1),
    ]
}

/// A grid rectangle kept free of buildings, in local metres.
fn open_area(r: &layout::GridRect) -> Polygon {
    Polygon {
        exterior: ring_ccw(r),
        holes: Vec::new(),
    }
}

/// A generated city in local metres.
#[derive(Clone, Debug)]
pub struct GeneratedCity {
    /// Exactly the requested number, ids "b0", "b1", ... in order.
    pub buildings: Vec<GeneratedBuilding>,
    /// The open square (a rectangle kept free of buildings).
    pub square: Polygon,
    /// The river-like strip across the whole street plan (kept free of buildings).
    pub river: Polygon,
}

/// The city's buildings in local metres: exactly `params.buildings` of them,
/// filled block by block from the centre outwards.
pub fn generate_buildings(params: &GenerateParams) -> Vec<GeneratedBuilding> {
    generate_city(params).buildings
}

/// The whole city in local metres: buildings, square and river.
pub fn generate_city(params: &GenerateParams) -> GeneratedCity {
    fill_plan(params, 1.5, |rng, rect| {
        buildings::fill_block(rng, rect)
            .into_iter()
            .map(|b| {
                let footprint = Polygon {
                    exterior: ring_ccw(&b.outer),
                    holes: b
                        .hole
                        .iter()
                        .map(|h| {
                            let mut ring = ring_ccw(h);
                            ring.reverse();
                            ring
                        })
                        .collect(),
                };
                (b.kind, b.height, footprint)
            })
            .collect()
    })
}

/// Exactly `params.buildings` buildings, ids "b0", "b1", ..., taken block
/// by block from the centre outwards of a street plan of half-size
/// `half_factor * radius + 300` m (doubled until the blocks suffice), the
/// radius that of a disc of the target area. `fill` gives a block's
/// buildings (kind, height, footprint) from the block's own random stream.
fn fill_plan(
    params: &GenerateParams,
    half_factor: f64,
    fill: impl Fn(&mut ChaCha8Rng, layout::GridRect) -> Vec<(Kind, f64, Polygon)>,
) -> GeneratedCity {
    let n = params.buildings;
    let radius = (n.max(1) as f64 / BUILDINGS_PER_KM2 / std::f64::consts::PI).sqrt() * 1000.0;
    let mut half = half_factor * radius + 300.0;
    loop {
        let plan = layout::plan(&mut stream(params.seed, 0), half, radius);
        let mut out = Vec::with_capacity(n);
        'blocks: for block in plan.blocks.iter().filter(|b| !b.square) {
            let id = 1 + ((block.row as u64) << 32 | block.column as u64);
            for (kind, height, footprint) in fill(&mut stream(params.seed, id), block.rect) {
                if out.len() == n {
                    break 'blocks;
                }
                out.push(GeneratedBuilding {
                    id: format!("b{}", out.len()),
                    kind,
                    height,
                    footprint,
                });
            }
        }
        if out.len() == n {
            return GeneratedCity {
                buildings: out,
                square: open_area(&plan.square),
                river: open_area(&plan.river),
            };
        }
        half *= 2.0;
    }
}

/// A lon/lat GeoJSON FeatureCollection (RFC 7946) of the generated city,
/// deterministic for given parameters.
pub fn generate_geojson(params: &GenerateParams) -> String {
    geojson::write(&generate_buildings(params), &frame())
}
