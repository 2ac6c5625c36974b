//! Bad input files: `citypvs bake BAD -o OUT.pvs` must fail with exit status
//! 2 and a one-line message naming the file (and the feature where one is at
//! fault) and what is wrong, without writing OUT.pvs.

use std::path::Path;
use std::process::Command;

/// Write `contents` to `file_name` in a fresh directory, bake it, and return
/// the error message after checking status, one line and no output file.
fn bake_error(file_name: &str, contents: &[u8], extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join(file_name);
    std::fs::write(&input, contents).unwrap();
    let output = dir.path().join("OUT.pvs");
    let run = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .arg("bake")
        .arg(&input)
        .arg("-o")
        .arg(&output)
        .arg("--quiet")
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert_eq!(run.status.code(), Some(2), "stderr: {stderr}");
    assert!(!output.exists(), "OUT.pvs was written");
    let message = stderr.trim_end();
    assert_eq!(message.lines().count(), 1, "not one line: {message}");
    assert!(message.starts_with("error: "), "{message}");
    assert!(
        message.contains(&input.display().to_string()),
        "the message does not name the file: {message}"
    );
    eprintln!("{message}");
    message.to_string()
}

fn assert_mentions(message: &str, words: &[&str]) {
    for w in words {
        assert!(message.contains(w), "{w:?} missing from: {message}");
    }
}

fn collection(features: &[&str]) -> Vec<u8> {
    format!(
        "{{\"type\":\"FeatureCollection\",\"features\":[\n{}\n]}}",
        features.join(",\n")
    )
    .into_bytes()
}

/// A Polygon feature with the given id, properties and first position.
fn feature(id: &str, props: &str, x: &str, y: &str) -> String {
    format!(
        "{{\"type\":\"Feature\",\"id\":\"{id}\",\"properties\":{{{props}}},\"geometry\":{{\"type\":\"Polygon\",\"coordinates\":[[[{x},{y}],[25.0001,60.0],[25.0001,60.0001],[25.0,60.0001],[{x},{y}]]]}}}}"
    )
}

fn good(id: &str) -> String {
    feature(id, "\"height\":10", "25.0", "60.0")
}

#[test]
fn empty_file() {
    let m = bake_error("empty.geojson", b"", &[]);
    assert_mentions(&m, &["empty"]);
    let m = bake_error("blank.geojson", b"  \n\n", &[]);
    assert_mentions(&m, &["empty"]);
}

#[test]
fn wrong_format() {
    let m = bake_error("city.csv", b"id,height\nb1,12\n", &[]);
    assert_mentions(&m, &["not a GeoJSON, CityJSON or OSM PBF file"]);
    let m = bake_error(
        "image.png",
        &[0x89, b'P', b'N', b'G', 13, 10, 26, 10, 0, 0],
        &[],
    );
    assert_mentions(&m, &["not a GeoJSON, CityJSON or OSM PBF file"]);
    let m = bake_error("topo.json", b"{\"type\":\"Topology\",\"objects\":{}}", &[]);
    assert_mentions(&m, &["FeatureCollection", "Topology"]);
}

#[test]
fn json_syntax_error_names_line_and_column() {
    let text =
        "{\"type\":\"FeatureCollection\",\n\"features\":[\n{\"type\":\"Feature\" \"id\":1}\n]}";
    let m = bake_error("broken.geojson", text.as_bytes(), &[]);
    assert_mentions(&m, &["not valid JSON", "line 3", "column"]);
}

#[test]
fn collection_without_buildings() {
    let m = bake_error("none.geojson", &collection(&[]), &[]);
    assert_mentions(&m, &["no buildings"]);
    let point = "{\"type\":\"Feature\",\"id\":\"p\",\"properties\":{},\"geometry\":{\"type\":\"Point\",\"coordinates\":[25,60]}}";
    let m = bake_error("points.geojson", &collection(&[point]), &[]);
    assert_mentions(&m, &["no buildings", "p", "Point"]);
}

#[test]
fn nan_and_infinite_coordinates() {
    let m = bake_error(
        "nan.geojson",
        &collection(&[&good("a"), &feature("b", "", "NaN", "60.0")]),
        &[],
    );
    assert_mentions(&m, &["line 3", "NaN"]);
    let m = bake_error(
        "inf.geojson",
        &collection(&[&good("a"), &feature("b", "", "1e999", "60.0")]),
        &[],
    );
    assert_mentions(&m, &["line 3", "out of range"]);
}

#[test]
fn bad_heights_name_the_feature() {
    for (height, why) in [
        ("-5", "not positive"),
        ("0", "not positive"),
        ("\"0 m\"", "not positive"),
        ("5000", "absurd"),
        ("\"tall\"", "not a length"),
    ] {
        let bad = feature("b7", &format!("\"height\":{height}"), "25.0", "60.0");
        let m = bake_error("heights.geojson", &collection(&[&good("a"), &bad]), &[]);
        assert_mentions(&m, &["\"b7\"", "index 1", why]);
    }
    let m = bake_error(
        "levels.geojson",
        &collection(&[&feature("L", "\"building:levels\":0", "25.0", "60.0")]),
        &[],
    );
    assert_mentions(&m, &["\"L\"", "index 0", "building:levels"]);
    let m = bake_error(
        "default.geojson",
        &collection(&[&good("a")]),
        &["--default-height=-1"],
    );
    assert_mentions(&m, &["--default-height"]);
}

#[test]
fn duplicate_ids_name_both_features() {
    let m = bake_error(
        "dup.geojson",
        &collection(&[&good("x"), &good("y"), &good("x")]),
        &[],
    );
    assert_mentions(&m, &["duplicate id \"x\"", "index 0", "index 2"]);
}

#[test]
fn metres_given_as_lon_lat() {
    let metres = feature("m1", "", "500000", "6700000");
    let m = bake_error("metres.geojson", &collection(&[&metres]), &[]);
    assert_mentions(&m, &["\"m1\"", "not lon/lat", "--metric"]);
}

#[test]
fn strict_turns_a_repair_into_an_error() {
    let unclosed = "{\"type\":\"Feature\",\"id\":\"u\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[25.0,60.0],[25.0001,60.0],[25.0001,60.0001],[25.0,60.0001]]]}}";
    let m = bake_error("open.geojson", &collection(&[unclosed]), &["--strict"]);
    assert_mentions(&m, &["feature \"u\"", "not closed", "--strict"]);
}

#[test]
fn missing_file() {
    let run = Command::new(env!("CARGO_BIN_EXE_citypvs"))
        .args(["bake", "/nonexistent/city.geojson", "-o"])
        .arg(Path::new("/nonexistent/OUT.pvs"))
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("/nonexistent/city.geojson: cannot read")
    );
}

#[test]
fn coordinates_that_are_not_numbers() {
    let bad = feature("s", "", "\"25.0\"", "60.0");
    let m = bake_error("strings.geojson", &collection(&[&good("a"), &bad]), &[]);
    assert_mentions(&m, &["not valid GeoJSON", "line 3", "column"]);
    let short = "{\"type\":\"Feature\",\"id\":\"p1\",\"properties\":{},\"geometry\":{\"type\":\"Polygon\",\"coordinates\":[[[25.0],[25.1,60.0],[25.1,60.1],[25.0]]]}}";
    let m = bake_error("short.geojson", &collection(&[short]), &[]);
    assert_mentions(&m, &["two numbers", "line 2"]);
}
