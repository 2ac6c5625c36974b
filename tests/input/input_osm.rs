//! The Kotka OSM PBF extract and its GeoJSON conversion give the same
//! buildings: same ids, heights within 1 cm, footprints within 1 cm. Also a
//! truncated PBF fails with a clear message.

use std::collections::BTreeMap;
use std::path::Path;

use citypvs::input::{Format, InputOptions, read_city, read_city_bytes};
use citypvs::model::{Building, distance_to_segment, multipolygon_area, polygon_edges};
use glam::DVec2;

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// Largest distance from a vertex of `a` to the boundary of `b`.
fn one_sided_distance(a: &Building, b: &Building) -> f64 {
    let vertices: Vec<DVec2> = a
        .footprint
        .iter()
        .flat_map(|p| {
            std::iter::once(&p.exterior)
                .chain(&p.holes)
                .flatten()
                .copied()
        })
        .collect();
    vertices
        .iter()
        .map(|&v| {
            b.footprint
                .iter()
                .flat_map(polygon_edges)
                .map(|(s, t)| distance_to_segment(v, s, t))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn kotka_pbf_matches_its_geojson() {
    let options = InputOptions::default();
    let pbf = read_city(&fixture("kotka.osm.pbf"), &options).unwrap();
    let json = read_city(&fixture("kotka.geojson"), &options).unwrap();
    eprintln!(
        "pbf: {} buildings, {} repaired, {} skipped {:?}",
        pbf.buildings.len(),
        pbf.report.repaired.len(),
        pbf.report.skipped.len(),
        &pbf.report.skipped[..pbf.report.skipped.len().min(5)]
    );
    let by_id = |c: &citypvs::input::City| -> BTreeMap<String, Building> {
        c.buildings
            .iter()
            .map(|b| (b.id.clone(), b.clone()))
            .collect()
    };
    let (p, j) = (by_id(&pbf), by_id(&json));
    let only_pbf: Vec<&String> = p.keys().filter(|k| !j.contains_key(*k)).collect();
    let only_json: Vec<&String> = j.keys().filter(|k| !p.contains_key(*k)).collect();
    assert!(
        only_pbf.is_empty() && only_json.is_empty(),
        "ids differ: only in PBF {} {:?}, only in GeoJSON {} {:?}",
        only_pbf.len(),
        &only_pbf[..only_pbf.len().min(10)],
        only_json.len(),
        &only_json[..only_json.len().min(10)]
    );
    assert_eq!(pbf.buildings.len(), 2171);
    // Both are centred on the same buildings, so local frames agree.
    assert_eq!(pbf.frame, json.frame);
    let mut worst: f64 = 0.0;
    let mut open_sided = Vec::new();
    for (id, a) in &p {
        let b = &j[id];
        assert!(
            (a.height - b.height).abs() < 0.01,
            "{id}: {} vs {}",
            a.height,
            b.height
        );
        // The GeoJSON conversion kept no `building` tags: the PBF's roofs
        // and carports (open-sided, never occluders) occlude there.
        if a.occludes != b.occludes {
            assert!(!a.occludes && b.occludes, "{id}");
            open_sided.push(id.clone());
        }
        let d = one_sided_distance(a, b).max(one_sided_distance(b, a));
        assert!(d < 0.01, "{id}: footprints differ by {d} m");
        worst = worst.max(d);
    }
    eprintln!("largest footprint difference: {worst:e} m");
    eprintln!("open-sided in the PBF: {open_sided:?}");
    assert_eq!(open_sided, vec!["w369849807".to_string()]);
}

#[test]
fn truncated_pbf_is_a_clear_error() {
    let bytes = std::fs::read(fixture("kotka.osm.pbf")).unwrap();
    let cut = &bytes[..bytes.len() / 2];
    let err = crate::common::error_of(
        read_city_bytes(cut, "cut.osm.pbf", &InputOptions::default()),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.starts_with("cut.osm.pbf: ") && err.contains("truncated"),
        "{err}"
    );
    // Forcing the format on a GeoJSON file gives a PBF error, not a panic.
    let json = std::fs::read(fixture("kotka.geojson")).unwrap();
    let forced = InputOptions {
        format: Some(Format::OsmPbf),
        ..InputOptions::default()
    };
    let err = crate::common::error_of(
        read_city_bytes(&json, "k.geojson", &forced),
        citypvs::ErrorKind::Input,
    );
    assert!(err.starts_with("k.geojson: "), "{err}");
}

/// A minimal OSM PBF writer (uncompressed blobs, plain nodes) for small test files.
mod pbf {
    fn varint(out: &mut Vec<u8>, mut v: u64) {
        while v >= 0x80 {
            out.push((v as u8) | 0x80);
            v >>= 7;
        }
        out.push(v as u8);
    }

    fn zigzag(v: i64) -> u64 {
        ((v << 1) ^ (v >> 63)) as u64
    }

    fn key(out: &mut Vec<u8>, field: u32, wire: u8) {
        varint(out, ((field as u64) << 3) | wire as u64);
    }

    pub fn bytes_field(out: &mut Vec<u8>, field: u32, data: &[u8]) {
        key(out, field, 2);
        varint(out, data.len() as u64);
        out.extend_from_slice(data);
    }

    pub fn int_field(out: &mut Vec<u8>, field: u32, v: u64) {
        key(out, field, 0);
        varint(out, v);
    }

    pub fn sint_field(out: &mut Vec<u8>, field: u32, v: i64) {
        int_field(out, field, zigzag(v));
    }

    pub fn packed(out: &mut Vec<u8>, field: u32, values: &[u64]) {
        let mut data = Vec::new();
        for &v in values {
            varint(&mut data, v);
        }
        bytes_field(out, field, &data);
    }

    pub fn packed_delta_sint(out: &mut Vec<u8>, field: u32, values: &[i64]) {
        let mut last = 0;
        let deltas: Vec<u64> = values
            .iter()
            .map(|&v| {
                let d = zigzag(v - last);
                last = v;
                d
            })
            .collect();
        packed(out, field, &deltas);
    }

    /// Element tags as string-table indices.
    pub struct Strings(pub Vec<String>);

    impl Strings {
        pub fn index(&mut self, s: &str) -> u64 {
            match self.0.iter().position(|x| x == s) {
                Some(i) => i as u64,
                None => {
                    self.0.push(s.to_string());
                    (self.0.len() - 1) as u64
                }
            }
        }

        pub fn tags(&mut self, out: &mut Vec<u8>, tags: &[(&str, &str)]) {
            let keys: Vec<u64> = tags.iter().map(|t| self.index(t.0)).collect();
            let vals: Vec<u64> = tags.iter().map(|t| self.index(t.1)).collect();
            packed(out, 2, &keys);
            packed(out, 3, &vals);
        }
    }

    /// A plain node (no tags) at `lon`, `lat` degrees, added to `group`.
    pub fn node(group: &mut Vec<u8>, id: i64, (lon, lat): (f64, f64)) {
        let mut node = Vec::new();
        sint_field(&mut node, 1, id);
        packed(&mut node, 2, &[]);
        sint_field(&mut node, 8, (lat * 1e7).round() as i64);
        sint_field(&mut node, 9, (lon * 1e7).round() as i64);
        bytes_field(group, 1, &node);
    }

    /// A way with node ids `refs` and `tags`, added to `group`.
    pub fn way(s: &mut Strings, group: &mut Vec<u8>, id: i64, refs: &[i64], tags: &[(&str, &str)]) {
        let mut way = Vec::new();
        int_field(&mut way, 1, id as u64);
        s.tags(&mut way, tags);
        packed_delta_sint(&mut way, 8, refs);
        bytes_field(group, 3, &way);
    }

    /// A relation with `members` (id and role, each of type number
    /// `member_type`) and `tags`, added to `group`.
    pub fn relation(
        s: &mut Strings,
        group: &mut Vec<u8>,
        id: i64,
        (members, member_type): (&[(i64, &str)], u64),
        tags: &[(&str, &str)],
    ) {
        let mut rel = Vec::new();
        int_field(&mut rel, 1, id as u64);
        s.tags(&mut rel, tags);
        let roles: Vec<u64> = members.iter().map(|m| s.index(m.1)).collect();
        packed(&mut rel, 8, &roles);
        let ids: Vec<i64> = members.iter().map(|m| m.0).collect();
        packed_delta_sint(&mut rel, 9, &ids);
        packed(&mut rel, 10, &vec![member_type; members.len()]);
        bytes_field(group, 4, &rel);
    }

    fn blob(out: &mut Vec<u8>, kind: &str, message: &[u8]) {
        let mut blob = Vec::new();
        bytes_field(&mut blob, 1, message);
        int_field(&mut blob, 2, message.len() as u64);
        let mut header = Vec::new();
        bytes_field(&mut header, 1, kind.as_bytes());
        int_field(&mut header, 3, blob.len() as u64);
        out.extend_from_slice(&(header.len() as u32).to_be_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(&blob);
    }

    /// A whole file: a header blob and one data blob holding `group` (a
    /// PrimitiveGroup's bytes) with string table `strings`.
    pub fn file(strings: &Strings, groups: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut header = Vec::new();
        bytes_field(&mut header, 4, b"OsmSchema-V0.6");
        blob(&mut out, "OSMHeader", &header);
        let mut table = Vec::new();
        for s in &strings.0 {
            bytes_field(&mut table, 1, s.as_bytes());
        }
        let mut block = Vec::new();
        bytes_field(&mut block, 1, &table);
        for g in groups {
            bytes_field(&mut block, 2, g);
        }
        blob(&mut out, "OSMData", &block);
        out
    }
}

/// An element's tags.
type Tags = Vec<(&'static str, &'static str)>;
/// A relation's members: way id and role.
type Members = Vec<(i64, &'static str)>;

/// A tiny extract: a building way, a lifted building part, an unclosed
/// building way, a multipolygon building with a courtyard whose outer ring is
/// split over two ways (one drawn backwards), and a relation with a missing way.
fn tiny_extract() -> Vec<u8> {
    tiny_extract_with_member_type(1)
}

/// [`tiny_extract`] with every relation member's type number `member_type`
/// (0 node, 1 way, 2 relation; anything else is not in the format).
fn tiny_extract_with_member_type(member_type: u64) -> Vec<u8> {
    let mut s = pbf::Strings(vec![String::new()]);
    let square = |x: f64, y: f64, d: f64| [(x, y), (x + d, y), (x + d, y + d), (x, y + d)];
    let mut nodes_at: Vec<(f64, f64)> = Vec::new();
    nodes_at.extend(square(25.0, 60.0, 0.0002)); // 1-4: w10
    nodes_at.extend(square(25.001, 60.0, 0.0002)); // 5-8: w11
    nodes_at.extend([(25.002, 60.0), (25.0022, 60.0), (25.0022, 60.0002)]); // 9-11: w12
    nodes_at.extend(square(25.003, 60.0, 0.0004)); // 12-15: r20 outer
    nodes_at.extend(square(25.0031, 60.0001, 0.0002)); // 16-19: r20 inner
    let mut group_nodes = Vec::new();
    for (i, &at) in nodes_at.iter().enumerate() {
        pbf::node(&mut group_nodes, i as i64 + 1, at);
    }
    let ways: Vec<(i64, Vec<i64>, Tags)> = vec![
        (
            10,
            vec![1, 2, 3, 4, 1],
            vec![("building", "yes"), ("height", "12 m")],
        ),
        (
            11,
            vec![5, 6, 7, 8, 5],
            vec![
                ("building:part", "yes"),
                ("min_height", "6"),
                ("height", "10"),
            ],
        ),
        (12, vec![9, 10, 11], vec![("building", "yes")]),
        (13, vec![1, 2, 3, 1], vec![("building", "no")]),
        (21, vec![12, 13, 14], vec![]),
        (22, vec![12, 15, 14], vec![]),
        (23, vec![16, 19, 18, 17, 16], vec![]),
    ];
    let mut group_ways = Vec::new();
    for (id, refs, tags) in &ways {
        pbf::way(&mut s, &mut group_ways, *id, refs, tags);
    }
    let relations: Vec<(i64, Members, Tags)> = vec![
        (
            20,
            vec![(21, "outer"), (23, "inner"), (22, "outer")],
            vec![
                ("type", "multipolygon"),
                ("building", "yes"),
                ("building:levels", "3"),
            ],
        ),
        (
            30,
            vec![(21, "outer"), (99, "outer")],
            vec![("type", "multipolygon"), ("building", "yes")],
        ),
    ];
    let mut group_relations = Vec::new();
    for (id, members, tags) in &relations {
        pbf::relation(
            &mut s,
            &mut group_relations,
            *id,
            (members, member_type),
            tags,
        );
    }
    pbf::file(&s, &[group_nodes, group_ways, group_relations])
}

#[test]
fn relations_parts_and_broken_features() {
    let bytes = tiny_extract();
    let city = read_city_bytes(&bytes, "tiny.osm.pbf", &InputOptions::default()).unwrap();
    let ids: Vec<&str> = city.buildings.iter().map(|b| b.id.as_str()).collect();
    assert_eq!(ids, ["w10", "w11", "r20"]);
    assert_eq!(city.report.features_read, 5);
    let skipped: Vec<(&str, &str)> = city
        .report
        .skipped
        .iter()
        .map(|w| (w.feature.as_str(), w.message.as_str()))
        .collect();
    assert_eq!(skipped.len(), 2, "{skipped:?}");
    assert!(
        skipped[0].0 == "w12" && skipped[0].1.contains("not closed"),
        "{skipped:?}"
    );
    assert!(
        skipped[1].0 == "r30" && skipped[1].1.contains("99"),
        "{skipped:?}"
    );
    let heights: Vec<f64> = city.buildings.iter().map(|b| b.height).collect();
    assert_eq!(heights, [12.0, 10.0, 9.0]);
    let occludes: Vec<bool> = city.buildings.iter().map(|b| b.occludes).collect();
    assert_eq!(occludes, [true, false, true]);
    // The relation: one polygon with the courtyard as a hole. Its outer
    // square has twice w10's side and the hole w10's side: 4 - 1 = 3 times w10's area.
    let r20 = &city.buildings[2].footprint;
    assert_eq!(r20.len(), 1);
    assert_eq!(r20[0].holes.len(), 1);
    let w10 = multipolygon_area(&city.buildings[0].footprint);
    let r = multipolygon_area(r20);
    assert!((r / w10 - 3.0).abs() < 0.01, "{r} {w10}");

    let strict = InputOptions {
        strict: true,
        ..InputOptions::default()
    };
    let err = crate::common::error_of(
        read_city_bytes(&bytes, "tiny.osm.pbf", &strict),
        citypvs::ErrorKind::Input,
    );
    assert!(err.contains("\"w12\"") && err.contains("--strict"), "{err}");
}

#[test]
fn relation_member_of_unknown_type_is_a_clear_error() {
    // The PBF decoder panics on a member type it does not know; the reader
    // catches that and names the relation.
    for member_type in [3, 7, 1 << 30] {
        let bytes = tiny_extract_with_member_type(member_type);
        let err = crate::common::error_of(
            read_city_bytes(&bytes, "bad.osm.pbf", &InputOptions::default()),
            citypvs::ErrorKind::Input,
        );
        assert!(
            err.starts_with("bad.osm.pbf: ") && err.contains("relation 20"),
            "{err}"
        );
    }
    // Members that are nodes or relations are not ways: the relations lose
    // their rings and are skipped, which is not an error.
    for member_type in [0, 2] {
        let bytes = tiny_extract_with_member_type(member_type);
        let city = read_city_bytes(&bytes, "odd.osm.pbf", &InputOptions::default()).unwrap();
        let ids: Vec<&str> = city.buildings.iter().map(|b| b.id.as_str()).collect();
        assert_eq!(ids, ["w10", "w11"]);
    }
}

/// A building relation whose members are one long way listed again and
/// again: a file of some 11 kB that would make the reader copy the way's
/// nodes thousands of times.
fn repeated_member_extract(refs: usize, repeats: usize) -> Vec<u8> {
    let mut s = pbf::Strings(vec![String::new()]);
    let ids: Vec<i64> = (1..=refs as i64).collect();
    let mut group_ways = Vec::new();
    pbf::way(&mut s, &mut group_ways, 40, &ids, &[]);
    let mut group_relations = Vec::new();
    let tags = [("type", "multipolygon"), ("building", "yes")];
    let members = vec![(40, "outer"); repeats];
    pbf::relation(&mut s, &mut group_relations, 50, (&members, 1), &tags);
    pbf::file(&s, &[group_ways, group_relations])
}

#[test]
fn a_relation_repeating_a_long_way_is_refused_before_it_is_copied() {
    let bytes = repeated_member_extract(5_000, 2_000);
    assert!(bytes.len() < 12_000, "{}", bytes.len());
    let err = crate::common::error_of(
        read_city_bytes(&bytes, "bomb.osm.pbf", &InputOptions::default()),
        citypvs::ErrorKind::Input,
    );
    assert!(
        err.starts_with("bomb.osm.pbf: ") && err.contains("more than 1048576 node references"),
        "{err}"
    );
    // The same relation with few repeats is read (and skipped: its one
    // way does not close, and its nodes are not in the file).
    let bytes = repeated_member_extract(5_000, 3);
    let err = crate::common::error_of(
        read_city_bytes(&bytes, "few.osm.pbf", &InputOptions::default()),
        citypvs::ErrorKind::Input,
    );
    assert!(err.contains("no buildings"), "{err}");
}

#[test]
fn long_tag_values_are_not_copied() {
    let long = "9".repeat(100_000);
    let mut s = pbf::Strings(vec![String::new()]);
    let mut group_nodes = Vec::new();
    for (i, &at) in [(25.0, 60.0), (25.0002, 60.0), (25.0002, 60.0002)]
        .iter()
        .enumerate()
    {
        pbf::node(&mut group_nodes, i as i64 + 1, at);
    }
    let mut group_ways = Vec::new();
    let tags = [("building", "yes"), ("height", &long), ("name", &long)];
    for id in 1..=200 {
        pbf::way(&mut s, &mut group_ways, id, &[1, 2, 3, 1], &tags);
    }
    let bytes = pbf::file(&s, &[group_nodes, group_ways]);
    let city = read_city_bytes(&bytes, "long.osm.pbf", &InputOptions::default()).unwrap();
    assert_eq!(city.buildings.len(), 200);
    assert!(city.buildings.iter().all(|b| b.height == 9.0));
    let notes: Vec<&str> = city
        .report
        .repaired
        .iter()
        .map(|w| w.message.as_str())
        .collect();
    assert!(
        notes
            .iter()
            .any(|m| m.contains("height=\"(100000 bytes, not read)\" ignored")),
        "{:?}",
        &notes[..notes.len().min(3)]
    );
    assert!(notes.iter().all(|m| m.len() < 300));
}
