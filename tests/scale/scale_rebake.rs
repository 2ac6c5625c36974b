//! Incremental bakes (`bake --previous`): after single-building edits of a
//! generated city (move, delete, add, raise, lower) the file is byte for
//! byte the one a full bake of the edited city writes, while cells are
//! really copied (with the edited city prepared from a geometry cache of
//! the base), and an edit of one house of a row changes no other member
//! whose occluders it leaves alone; a previous file of other settings, an unreadable one or a
//! version 1 file is refused with one line.

use std::path::Path;
use std::process::Output;

use serde_json::Value;

use super::scale_resume::generate;

fn run(dir: &Path, args: &[&str]) -> Output {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .current_dir(dir)
        .args(args)
        .env_remove("CITYPVS_SHARD")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "citypvs {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Shift every coordinate of a GeoJSON geometry.
fn shift(v: &mut Value, dx: f64, dy: f64) {
    match v {
        Value::Array(a) if a.len() == 2 && a[0].is_number() => {
            a[0] = (a[0].as_f64().unwrap() + dx).into();
            a[1] = (a[1].as_f64().unwrap() + dy).into();
        }
        Value::Array(a) => a.iter_mut().for_each(|c| shift(c, dx, dy)),
        _ => {}
    }
}

/// A small linear congruential generator, so the edits are the same every run.
struct Lcg(u64);
impl Lcg {
    fn next(&mut self, n: usize) -> usize {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 33) % n as u64) as usize
    }
}

const SETTINGS: [&str; 4] = ["--eps", "2", "--threads", "2"];

fn bake(dir: &Path, city: &str, out: &str, previous: Option<&str>) -> Value {
    bake_cached(dir, city, out, previous, None)
}

fn bake_cached(
    dir: &Path,
    city: &str,
    out: &str,
    previous: Option<&str>,
    cache: Option<&str>,
) -> Value {
    let mut args = vec!["bake", city, "-o", out, "--json", "-q"];
    args.extend(SETTINGS);
    if let Some(p) = previous {
        args.extend(["--previous", p]);
    }
    if let Some(c) = cache {
        args.extend(["--geometry-cache", c]);
    }
    let o = run(dir, &args);
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn twenty_single_building_edits_give_the_full_bakes_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "base.geojson", "100", "11");
    let base: Value =
        serde_json::from_slice(&std::fs::read(d.join("base.geojson")).unwrap()).unwrap();
    // The base is baked without the geometry cache and the rebakes take
    // from one (made by preparing the base), so each edit's cells and
    // occluders come partly from the cache, and the bytes are still the
    // full bake's.
    bake(d, "base.geojson", "base.pvs", None);
    run(
        d,
        &[
            "prepare",
            "base.geojson",
            "--eps",
            "2",
            "--geometry-cache",
            "base.cache",
        ],
    );
    let kinds = ["move", "delete", "add", "raise", "lower"];
    let mut rng = Lcg(2026);
    let (mut copied, mut cells, mut in_part, mut unprobed) = (0u64, 0u64, 0u64, 0u64);
    let mut probe_failed = 0u64;
    let (mut taken, mut computed) = (0u64, 0u64);
    for edit in 0..20 {
        let kind = kinds[edit % kinds.len()];
        let mut city = base.clone();
        let features = city["features"].as_array_mut().unwrap();
        let i = rng.next(features.len());
        let height = features[i]["properties"]["height"].as_f64().unwrap_or(9.0);
        match kind {
            "move" => shift(&mut features[i]["geometry"]["coordinates"], 3e-5, 2e-5),
            "delete" => {
                features.remove(i);
            }
            "add" => {
                let mut f = features[i].clone();
                f["id"] = format!("added-{edit}").into();
                shift(&mut f["geometry"]["coordinates"], 4e-5, -3e-5);
                features.push(f);
            }
            "raise" => features[i]["properties"]["height"] = (height * 1.5 + 3.0).into(),
            _ => features[i]["properties"]["height"] = (height * 0.5).max(2.5).into(),
        }
        std::fs::write(d.join("edit.geojson"), serde_json::to_vec(&city).unwrap()).unwrap();
        bake(d, "edit.geojson", "full.pvs", None);
        std::fs::copy(d.join("base.cache"), d.join("edit.cache")).unwrap();
        let s = bake_cached(
            d,
            "edit.geojson",
            "inc.pvs",
            Some("base.pvs"),
            Some("edit.cache"),
        );
        let cache = &s["geometry_cache"];
        assert!(cache["ignored"].is_null(), "edit {edit}: {cache}");
        taken += cache["taken"].as_u64().unwrap();
        computed += cache["computed"].as_u64().unwrap();
        if kind != "raise" && kind != "lower" {
            assert!(
                cache["computed"].as_u64().unwrap() > 0,
                "edit {edit} ({kind}): {cache}"
            );
        }
        let full = std::fs::read(d.join("full.pvs")).unwrap();
        let inc = std::fs::read(d.join("inc.pvs")).unwrap();
        assert!(
            full == inc,
            "edit {edit} ({kind} feature {i}): the incremental bake differs from the full bake ({})",
            s["rebake"]
        );
        let (c, r) = (
            s["cells_copied"].as_u64().unwrap(),
            s["cells_recomputed"].as_u64().unwrap(),
        );
        assert_eq!(c + r, s["cells"].as_u64().unwrap());
        copied += c;
        cells += c + r;
        in_part += s["rebake"]["cells_solved_in_part"].as_u64().unwrap();
        probe_failed += s["rebake"]["cells_probe_failed"].as_u64().unwrap();
        unprobed += s["rebake"]["objects_changed_new"].as_u64().unwrap()
            - s["rebake"]["objects_probed"].as_u64().unwrap();
    }
    // Most shapes came from the cache; the edited ones were computed.
    assert!(
        taken > 20 * computed,
        "{taken} shapes taken, {computed} computed"
    );
    // Some edits changed a block's occluders only for its other members,
    // which the probe passes over (shown hidden by their old versions).
    assert!(unprobed > 0, "no edit left a changed member unprobed");
    // The cells solved only for the objects in a change's directions are
    // among those compared.
    assert!(
        in_part * 10 > cells - copied,
        "only {in_part} of {} cells solved again were solved in part",
        cells - copied
    );
    // Some cells failed only the probe: they are solved in part for the
    // objects they saw and the changed ones only.
    assert!(probe_failed > 0, "no cell failed only the probe");
    // The test is not passed by solving everything again.
    assert!(
        copied * 10 > cells,
        "only {copied} of {cells} cells were copied over the 20 edits"
    );
}

/// A metric GeoJSON city: a row of seven touching 10 m squares along x
/// (ids `row0` to `row6`) with the given heights, and eight free-standing
/// buildings around it.
fn row_city(heights: [f64; 7]) -> Vec<u8> {
    let square = |x: f64, y: f64, w: f64| {
        serde_json::json!({"type": "Polygon", "coordinates": [[
            [x, y], [x + w, y], [x + w, y + w], [x, y + w], [x, y]
        ]]})
    };
    let mut features: Vec<Value> = heights
        .iter()
        .enumerate()
        .map(|(i, &h)| {
            serde_json::json!({"type": "Feature", "id": format!("row{i}"),
                "properties": {"height": h}, "geometry": square(10.0 * i as f64, 0.0, 10.0)})
        })
        .collect();
    for k in 0..8 {
        let (x, y) = (
            -40.0 + 20.0 * k as f64,
            if k % 2 == 0 { 40.0 } else { -40.0 },
        );
        features.push(
            serde_json::json!({"type": "Feature", "id": format!("house{k}"),
            "properties": {"height": 8.0 + k as f64}, "geometry": square(x, y, 8.0)}),
        );
    }
    serde_json::to_vec(&serde_json::json!({"type": "FeatureCollection", "features": features}))
        .unwrap()
}

#[test]
fn raising_one_house_of_a_row_changes_only_that_house() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bake = |city: &str, out: &str, previous: Option<&str>| -> Value {
        let mut args = vec!["bake", city, "-o", out, "--json", "-q", "--metric"];
        args.extend(SETTINGS);
        if let Some(p) = previous {
            args.extend(["--previous", p]);
        }
        serde_json::from_slice(&run(d, &args).stdout).unwrap()
    };
    std::fs::write(d.join("base.geojson"), row_city([10.0; 7])).unwrap();
    bake("base.geojson", "base.pvs", None);
    // Raised, the middle house adds a level of its own: the row's common
    // level is the same polygon, and no other member lies under the new
    // one (all are lower), so only the raised house is a changed object.
    // Lowered, it splits the row's level in two: every member changes.
    for (height, changed) in [(16.0, 1), (6.0, 7)] {
        let mut heights = [10.0; 7];
        heights[3] = height;
        std::fs::write(d.join("edit.geojson"), row_city(heights)).unwrap();
        bake("edit.geojson", "full.pvs", None);
        let s = bake("edit.geojson", "inc.pvs", Some("base.pvs"));
        assert!(
            std::fs::read(d.join("full.pvs")).unwrap() == std::fs::read(d.join("inc.pvs")).unwrap(),
            "middle house at {height} m: the incremental bake differs from the full bake ({})",
            s["rebake"]
        );
        assert_eq!(
            s["rebake"]["objects_changed_new"].as_u64(),
            Some(changed),
            "{}",
            s["rebake"]
        );
        assert_eq!(
            s["rebake"]["objects_changed_old"].as_u64(),
            Some(changed),
            "{}",
            s["rebake"]
        );
    }
}

#[test]
fn a_rebake_of_an_unchanged_city_copies_every_block_and_writes_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "base.geojson", "100", "11");
    let s = bake(d, "base.geojson", "base.pvs", None);
    let again = bake(d, "base.geojson", "again.pvs", Some("base.pvs"));
    assert_eq!(
        std::fs::read(d.join("base.pvs")).unwrap(),
        std::fs::read(d.join("again.pvs")).unwrap()
    );
    let cells = s["cells"].as_u64().unwrap();
    assert!(cells > 512, "the city has {cells} cells, one block");
    assert_eq!(again["cells_copied"].as_u64(), Some(cells));
    assert_eq!(
        again["rebake"]["blocks_copied"].as_u64(),
        Some(cells.div_ceil(512))
    );
    assert_eq!(again["mean_visible"], s["mean_visible"]);
    assert_eq!(again["max_visible"], s["max_visible"]);
}

#[test]
fn an_edit_that_moves_the_frame_bakes_in_full_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    generate(d, "base.geojson", "60", "5");
    bake(d, "base.geojson", "base.pvs", None);
    // A copy of a building well outside the city moves the centre of the
    // buildings' bounding box, so the frame.
    let mut city: Value =
        serde_json::from_slice(&std::fs::read(d.join("base.geojson")).unwrap()).unwrap();
    let features = city["features"].as_array_mut().unwrap();
    let mut far = features[0].clone();
    far["id"] = "far-away".into();
    shift(&mut far["geometry"]["coordinates"], 4e-3, 0.0);
    features.push(far);
    std::fs::write(d.join("edit.geojson"), serde_json::to_vec(&city).unwrap()).unwrap();
    bake(d, "edit.geojson", "full.pvs", None);
    let s = bake(d, "edit.geojson", "inc.pvs", Some("base.pvs"));
    assert_eq!(
        std::fs::read(d.join("full.pvs")).unwrap(),
        std::fs::read(d.join("inc.pvs")).unwrap()
    );
    let why = s["rebake"]["full_because"].as_str().unwrap();
    assert!(why.contains("frame"), "{why}");
    assert_eq!(s["cells_copied"].as_u64(), Some(0));
    assert_eq!(s["cells_recomputed"], s["cells"]);
    assert!(!d.join("inc.pvs.citypvs-checkpoint").exists());
}

#[test]
fn a_previous_file_that_cannot_be_used_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    run(
        d,
        &[
            "generate",
            "--buildings",
            "12",
            "--seed",
            "3",
            "-o",
            "c.geojson",
        ],
    );
    bake(d, "c.geojson", "c.pvs", None);
    let refuse = |previous: &str, extra: &[&str], want: &str| {
        let mut args = vec![
            "bake",
            "c.geojson",
            "-o",
            "n.pvs",
            "-q",
            "--previous",
            previous,
        ];
        args.extend(SETTINGS);
        args.extend(extra);
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_citypvs"))
            .current_dir(d)
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(want) && err.contains(previous), "{err}");
        assert!(!d.join("n.pvs").exists());
    };
    refuse(
        "c.pvs",
        &["--eye-height", "2"],
        "other settings: eye-height 1.7 (now 2)",
    );
    refuse("c.pvs", &["--near-field", "40"], "near-field 48 (now 40)");
    std::fs::write(d.join("junk.pvs"), b"not a pvs file at all").unwrap();
    refuse("junk.pvs", &[], "junk.pvs");
    refuse("missing.pvs", &[], "cannot read");
    let mut v1 = std::fs::read(d.join("c.pvs")).unwrap();
    v1[8..12].copy_from_slice(&1u32.to_le_bytes());
    std::fs::write(d.join("v1.pvs"), v1).unwrap();
    refuse("v1.pvs", &[], "version 1");
}
