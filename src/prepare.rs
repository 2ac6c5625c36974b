//! Scene preparation: runs the front half of the pipeline (merge, shrink,
//! triangulate) over a city that has been read, and times each stage.

use std::time::Instant;

use crate::Result;
use crate::cells::{CellParams, Cells, triangulate_with};
use crate::geometry::memo::ShapeMemo;
use crate::geometry::{Block, Occluder, merge_blocks, shrink_blocks_with};
use crate::input::City;
use crate::settings::Settings;

/// Seconds spent in one named stage.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StageTime {
    pub stage: &'static str,
    pub seconds: f64,
}

/// A prepared scene: the city, its blocks, shrunk occluders and view cells,
/// and the settings they were made with.
#[derive(Clone, Debug)]
pub struct Scene {
    pub city: City,
    pub blocks: Vec<Block>,
    pub occluders: Vec<Occluder>,
    pub cells: Cells,
    pub settings: Settings,
    pub timings: Vec<StageTime>,
}

/// How the cells stage reads the settings.
pub fn cell_params(settings: &Settings) -> CellParams {
    CellParams {
        margin: settings.margin,
        max_edge: settings.max_cell_edge,
        region: settings.region.clone(),
        min_gap: settings.min_gap,
    }
}

/// [`prepare`] a city that took `read_seconds` to read: the scene's
/// timings start with that "read" stage.
pub fn prepare_read(
    city: City,
    read_seconds: f64,
    settings: &Settings,
    memo: &ShapeMemo,
) -> Result<Scene> {
    let mut scene = prepare_with(city, settings, memo)?;
    scene.timings.insert(
        0,
        StageTime {
            stage: "read",
            seconds: read_seconds,
        },
    );
    Ok(scene)
}

/// Run merge, shrink and triangulation over a city.
pub fn prepare(city: City, settings: &Settings) -> Result<Scene> {
    prepare_with(city, settings, &ShapeMemo::off())
}

/// [`prepare`], taking from `memo` every shrunk level and opened tile it
/// holds (the same bits as computing them).
pub fn prepare_with(city: City, settings: &Settings, memo: &ShapeMemo) -> Result<Scene> {
    let mut timings = Vec::new();
    let t = Instant::now();
    let blocks = merge_blocks(&city.buildings);
    timings.push(StageTime {
        stage: "merge",
        seconds: t.elapsed().as_secs_f64(),
    });
    let t = Instant::now();
    let occluders = shrink_blocks_with(&blocks, settings.eps, memo);
    timings.push(StageTime {
        stage: "erode",
        seconds: t.elapsed().as_secs_f64(),
    });
    let t = Instant::now();
    let cells = triangulate_with(&blocks, &cell_params(settings), memo)?;
    timings.push(StageTime {
        stage: "triangulate",
        seconds: t.elapsed().as_secs_f64(),
    });
    Ok(Scene {
        city,
        blocks,
        occluders,
        cells,
        settings: settings.clone(),
        timings,
    })
}

/// What preparation made, for printing or JSON.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PrepareSummary {
    pub features_read: usize,
    pub buildings: usize,
    pub repaired: usize,
    pub skipped: usize,
    pub warnings: Vec<crate::input::Warning>,
    pub blocks: usize,
    pub levels: usize,
    pub occluders: usize,
    pub cells: usize,
    pub region_area_m2: f64,
    pub footprint_area_m2: f64,
    pub free_area_m2: f64,
    /// Free area dropped as narrower than the minimum gap (or within the
    /// clearance along the footprints).
    pub dropped_area_m2: f64,
    /// The minimum gap used, metres.
    pub min_gap_m: f64,
    /// Cell quality: the smallest altitude of any cell (metres) and how many
    /// cells are thinner than [`THIN_CELL`].
    pub thinnest_cell_m: f64,
    pub thin_cells: usize,
    pub timings: Vec<StageTime>,
    /// How `--geometry-cache` was used, when it was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub geometry_cache: Option<crate::scale::geometry_cache::CacheReport>,
}

/// Cells with a smaller altitude than this (metres) count as thin.
pub const THIN_CELL: f64 = 0.05;

/// The smallest altitude of a triangle: twice its area over its longest edge.
pub fn triangle_altitude(t: &[glam::DVec2; 3]) -> f64 {
    let area2 = (t[1] - t[0]).perp_dot(t[2] - t[0]).abs();
    let longest = (0..3)
        .map(|i| t[i].distance(t[(i + 1) % 3]))
        .fold(0.0, f64::max);
    if longest > 0.0 { area2 / longest } else { 0.0 }
}

/// Summarise a prepared scene.
pub fn summary(scene: &Scene) -> PrepareSummary {
    use crate::model::{multipolygon_area, polygon_area};
    let report = &scene.city.report;
    let footprint_area: f64 = scene
        .blocks
        .iter()
        .filter_map(|b| b.levels.first())
        .map(|l| multipolygon_area(&l.area))
        .sum();
    let free_area: f64 = scene
        .cells
        .triangles
        .iter()
        .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]))
        .sum();
    let altitudes: Vec<f64> = scene
        .cells
        .triangles
        .iter()
        .map(triangle_altitude)
        .collect();
    let thinnest = altitudes.iter().copied().fold(f64::INFINITY, f64::min);
    let mut warnings = report.repaired.clone();
    warnings.extend(report.skipped.iter().cloned());
    PrepareSummary {
        features_read: report.features_read,
        buildings: scene.city.buildings.len(),
        repaired: report.repaired.len(),
        skipped: report.skipped.len(),
        warnings,
        blocks: scene.blocks.len(),
        levels: scene.blocks.iter().map(|b| b.levels.len()).sum(),
        occluders: scene.occluders.len(),
        cells: scene.cells.triangles.len(),
        region_area_m2: polygon_area(&scene.cells.region),
        footprint_area_m2: footprint_area,
        free_area_m2: free_area,
        dropped_area_m2: (scene.cells.open_area - free_area).max(0.0),
        min_gap_m: scene.cells.min_gap,
        thinnest_cell_m: if thinnest.is_finite() { thinnest } else { 0.0 },
        thin_cells: altitudes.iter().filter(|&&a| a < THIN_CELL).count(),
        timings: scene.timings.clone(),
        geometry_cache: None,
    }
}

impl PrepareSummary {
    /// A short human-readable report.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(s, "features read   {}", self.features_read);
        let _ = writeln!(
            s,
            "buildings       {} ({} repaired, {} skipped)",
            self.buildings, self.repaired, self.skipped
        );
        for w in self.warnings.iter().take(20) {
            let _ = writeln!(s, "  warning: feature {}: {}", w.feature, w.message);
        }
        if self.warnings.len() > 20 {
            let _ = writeln!(
                s,
                "  ... and {} more warnings (use --json to see all)",
                self.warnings.len() - 20
            );
        }
        let _ = writeln!(
            s,
            "blocks          {} ({} levels, {} shrunk occluders)",
            self.blocks, self.levels, self.occluders
        );
        let _ = writeln!(s, "cells           {}", self.cells);
        let _ = writeln!(
            s,
            "area            region {:.0} m2, footprints {:.0} m2, free {:.0} m2",
            self.region_area_m2, self.footprint_area_m2, self.free_area_m2
        );
        let _ = writeln!(
            s,
            "narrow          {:.0} m2 of free space dropped (min gap {} m)",
            self.dropped_area_m2, self.min_gap_m
        );
        let _ = writeln!(
            s,
            "cell quality    thinnest {:.3} m, {} cells ({:.2}%) thinner than {} m",
            self.thinnest_cell_m,
            self.thin_cells,
            100.0 * self.thin_cells as f64 / self.cells.max(1) as f64,
            THIN_CELL
        );
        if let Some(c) = &self.geometry_cache {
            let _ = writeln!(
                s,
                "geometry cache  {}: {} shapes taken, {} computed",
                c.file, c.taken, c.computed
            );
        }
        for t in &self.timings {
            let _ = writeln!(s, "time {:<11} {:.3} s", t.stage, t.seconds);
        }
        s
    }
}

/// The view cells as GeoJSON in the input's frame, each with its index.
pub fn cells_geojson(scene: &Scene) -> String {
    use crate::export::{Feature, Geometry, feature_collection};
    let features = scene
        .cells
        .triangles
        .iter()
        .enumerate()
        .map(|(i, t)| Feature {
            id: None,
            properties: format!("{{\"cell\":{i}}}"),
            geometry: Geometry::Polygon(vec![t.as_slice()]),
        });
    feature_collection(&scene.city.frame, None, features)
}

/// The shrunk occluders as GeoJSON in the input's frame, with block, level and height.
pub fn occluders_geojson(scene: &Scene) -> String {
    use crate::export::{Feature, Geometry, feature_collection};
    let features = scene.occluders.iter().map(|o| Feature {
        id: None,
        properties: format!(
            "{{\"block\":{},\"level\":{},\"height\":{:?}}}",
            o.block, o.level, o.height
        ),
        geometry: Geometry::MultiPolygon(o.shape.iter().map(Geometry::rings).collect()),
    });
    feature_collection(&scene.city.frame, None, features)
}
