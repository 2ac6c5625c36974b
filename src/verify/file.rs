//! Judging a `.pvs` file against the city it was baked from: the checks
//! that the two belong together (frame, objects, cells), the mapping of the
//! file's objects onto the city's buildings, the judge run, and the
//! violations' positions in the input's coordinates.

use std::collections::HashMap;

use super::{VerifyOptions, VerifyReport, verify_with_progress};
use crate::input::City;
use crate::model::Polygon;
use crate::pvs::PvsReader;
use crate::{Error, Result};

/// A city and a file to judge against it, with the names errors use.
pub struct FileUnderTest<'a> {
    pub city: &'a City,
    /// The city file's name, for messages.
    pub city_name: &'a str,
    pub reader: &'a PvsReader,
    /// The `.pvs` file's name, for messages.
    pub pvs_name: &'a str,
}

/// How to judge: which cells and viewpoints, and whether the file's cells
/// must be the ones citypvs prepares for the city.
pub struct FileCheck {
    pub options: VerifyOptions,
    /// Check that the file's cells are the ones `bake` makes for the city
    /// with the header's settings (false: judge them as they are).
    pub cells_must_match: bool,
    /// The region of interest the bake was given, in local metres.
    pub region: Option<Polygon>,
}

/// Judge the file against its city: every object of the file must be a
/// building of the city (and every building an object), the frames must
/// agree and, when asked, the cells must be the prepared ones. `tick` is
/// called with the number of viewpoints judged as they are. The report's
/// violations carry their input coordinates. An error when the file and
/// city do not belong together or nothing could be judged.
pub fn verify_file(
    file: &FileUnderTest,
    check: FileCheck,
    tick: &(dyn Fn(u64) + Sync),
) -> Result<VerifyReport> {
    let FileUnderTest {
        city,
        city_name,
        reader,
        pvs_name,
    } = *file;
    let info = reader.info();
    if reader.cell_count() == 0 {
        return Err(Error::mismatch(format!(
            "{pvs_name}: the file has no cells: there is nothing to check"
        )));
    }
    if info.frame != city.frame {
        return Err(Error::mismatch(format!(
            "{pvs_name}: baked in the frame \"{}\" but {city_name} reads in \"{}\"; read the city with the flags the bake used",
            info.frame.describe(),
            city.frame.describe()
        )));
    }
    let object_to_building = object_buildings(file)?;
    if check.cells_must_match {
        check_cells(file, check.region)?;
    }
    let mut visible = Vec::with_capacity(reader.cell_count());
    reader
        .for_each_visible(|_, set| {
            let mut set: Vec<u32> = set
                .iter()
                .map(|&o| object_to_building[o as usize])
                .collect();
            set.sort_unstable();
            visible.push(set);
            Ok(())
        })
        .map_err(|e| e.context(pvs_name))?;
    let mut report = verify_with_progress(
        &city.buildings,
        &reader.cell_triangles(),
        info.numbers.eye_height,
        &visible,
        &check.options,
        tick,
    );
    let to_input = |p: [f64; 3]| {
        let (x, y) = info.frame.to_input(glam::DVec2::new(p[0], p[1]));
        Some([x, y])
    };
    for v in &mut report.violations {
        v.viewpoint_input = to_input(v.viewpoint);
        v.witness_input = to_input(v.witness);
    }
    if report.cells_checked == 0 || report.judged_viewpoints() == 0 {
        return Err(Error::mismatch(format!(
            "{pvs_name}: nothing was judged: {} cells checked, {} viewpoints, all of them inside buildings \
             (the cells overlap the footprints: wrong city or wrong file?)",
            report.cells_checked, report.viewpoints
        )));
    }
    Ok(report)
}

/// Per object of the file, the index of the city's building with its id.
fn object_buildings(file: &FileUnderTest) -> Result<Vec<u32>> {
    let (city, city_name, pvs_name) = (file.city, file.city_name, file.pvs_name);
    let by_id: HashMap<&str, u32> = city
        .buildings
        .iter()
        .enumerate()
        .map(|(i, b)| (b.id.as_str(), i as u32))
        .collect();
    let object_to_building = file
        .reader
        .object_ids()
        .iter()
        .enumerate()
        .map(|(k, id)| {
            by_id.get(id.as_str()).copied().ok_or_else(|| {
                Error::mismatch(format!(
                    "{pvs_name}: object {k} (id {id}) is not a building of {city_name}: wrong city or wrong file"
                ))
            })
        })
        .collect::<Result<Vec<u32>>>()?;
    if object_to_building.len() != city.buildings.len() {
        return Err(Error::mismatch(format!(
            "{pvs_name}: has {} objects but {city_name} has {} buildings: wrong city or wrong file",
            object_to_building.len(),
            city.buildings.len()
        )));
    }
    Ok(object_to_building)
}

/// The file's cells must be the ones `bake` makes for this city with the
/// header's settings: same count, same triangles, in the same order.
fn check_cells(file: &FileUnderTest, region: Option<Polygon>) -> Result<()> {
    let (city_name, pvs_name) = (file.city_name, file.pvs_name);
    let info = file.reader.info();
    let with_region = region.is_some();
    let settings = info.settings(region).map_err(|e| e.context(pvs_name))?;
    let scene = crate::prepare::prepare(file.city.clone(), &settings)?;
    let ours = &scene.cells.triangles;
    let theirs = file.reader.cell_triangles();
    if *ours == theirs {
        return Ok(());
    }
    let differ = match ours.iter().zip(&theirs).position(|(a, b)| a != b) {
        Some(c) => format!("cell {c} differs"),
        None => format!("{} cells against {}", theirs.len(), ours.len()),
    };
    Err(Error::mismatch(format!(
        "{pvs_name}: its {} cells are not the {} cells prepared for {city_name} with the file's settings \
         (--eps {} --max-cell-edge {} --margin {}{}; {differ}): a different city, input flags or --region, \
         or a file not made by `citypvs bake` (--any-cells judges its cells as they are)",
        theirs.len(),
        ours.len(),
        info.numbers.eps,
        info.numbers.max_cell_edge,
        info.numbers.margin,
        if with_region {
            " and this --region"
        } else {
            ""
        },
    )))
}
