//! OpenStreetMap PBF extracts: closed ways and multipolygon relations
//! tagged `building=*` or `building:part=*`, their rings assembled from
//! member ways, heights from `height` / `building:levels` / `roof:levels`,
//! and lifted parts (`min_height`, `building:min_level`) kept as objects
//! that do not occlude. Ids are `"w<way id>"` and `"r<relation id>"`.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Cursor;

use osmpbf::{Element, ElementReader, RelMemberType};

use super::assemble::{Coordinates, Parsed, RawBuilding, RawPoint, RawPolygon};
use super::height::{check_height, parse_length, parse_number};
use super::{InputOptions, METRES_PER_LEVEL, Warning};
use crate::{Error, Result};

type Tags = BTreeMap<String, String>;

/// A building way or relation, in file order.
enum Feature {
    Way {
        id: i64,
        refs: Vec<i64>,
        tags: Tags,
    },
    Relation {
        id: i64,
        members: Vec<(i64, String)>,
        tags: Tags,
    },
}

impl Feature {
    fn id(&self) -> String {
        match self {
            Feature::Way { id, .. } => format!("w{id}"),
            Feature::Relation { id, .. } => format!("r{id}"),
        }
    }

    fn tags(&self) -> &Tags {
        match self {
            Feature::Way { tags, .. } | Feature::Relation { tags, .. } => tags,
        }
    }
}

fn is_yes(tags: &Tags, key: &str) -> bool {
    tags.get(key).is_some_and(|v| v != "no")
}

/// Buildings and building parts (see docs/input.md for why parts are kept).
fn is_building(tags: &Tags) -> bool {
    is_yes(tags, "building") || is_yes(tags, "building:part")
}

fn collect_tags<'a>(tags: impl Iterator<Item = (&'a str, &'a str)>) -> Tags {
    tags.map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

/// Run `f` over every element, turning reader errors into one clear message.
fn each_element(bytes: &[u8], name: &str, f: impl FnMut(Element<'_>)) -> Result<()> {
    ElementReader::new(Cursor::new(bytes))
        .for_each(f)
        .map_err(|e| {
            Error::input(format!(
                "{name}: the OSM PBF file is truncated or corrupt ({e})"
            ))
        })
}

/// Height, whether the part occludes, and notes about unusable tags.
/// Lifted parts and open-sided structures (`building=roof` / `carport`,
/// `building:part=roof`) do not occlude.
fn height(tags: &Tags, options: &InputOptions, notes: &mut Vec<String>) -> (f64, bool) {
    let open_sided = ["building", "building:part"].iter().any(|k| {
        tags.get(*k)
            .is_some_and(|v| super::opensided::is_open_sided(v))
    });
    let lifted = open_sided
        || tags
            .get("min_height")
            .and_then(|t| parse_length(t))
            .is_some_and(|m| m > 0.0)
        || tags
            .get("building:min_level")
            .and_then(|t| parse_number(t))
            .is_some_and(|l| l > 0.0);
    if let Some(text) = tags.get("height") {
        match parse_length(text)
            .ok_or_else(|| "not a length".to_string())
            .and_then(check_height)
        {
            Ok(h) => return (h, !lifted),
            Err(why) => notes.push(format!("height=\"{text}\" ignored ({why})")),
        }
    }
    if let Some(text) = tags.get("building:levels") {
        let roof = tags
            .get("roof:levels")
            .and_then(|t| parse_number(t))
            .unwrap_or(0.0);
        match parse_number(text)
            .ok_or_else(|| "not a number".to_string())
            .and_then(|levels| check_height((levels + roof.max(0.0)) * METRES_PER_LEVEL))
        {
            Ok(h) => return (h, !lifted),
            Err(why) => notes.push(format!("building:levels=\"{text}\" ignored ({why})")),
        }
    }
    (options.default_height, !lifted)
}

/// Join member ways into closed rings of node ids (each ring closed: first == last).
fn join_rings(mut pieces: Vec<Vec<i64>>) -> std::result::Result<Vec<Vec<i64>>, String> {
    pieces.retain(|p| p.len() >= 2);
    let mut rings = Vec::new();
    pieces.reverse();
    while let Some(mut ring) = pieces.pop() {
        while ring.first() != ring.last() {
            let end = *ring.last().unwrap_or(&0);
            let next = pieces
                .iter()
                .rposition(|p| p.first() == Some(&end) || p.last() == Some(&end));
            let Some(i) = next else {
                return Err(format!("a ring does not close (it ends at node {end})"));
            };
            let mut piece = pieces.remove(i);
            if piece.first() != Some(&end) {
                piece.reverse();
            }
            ring.extend_from_slice(&piece[1..]);
        }
        if ring.len() >= 4 {
            rings.push(ring);
        }
    }
    Ok(rings)
}

/// Node ids of a closed ring to open coordinates; `Err` names a missing node.
fn ring_points(
    ring: &[i64],
    nodes: &HashMap<i64, RawPoint>,
) -> std::result::Result<Vec<RawPoint>, String> {
    ring[..ring.len() - 1]
        .iter()
        .map(|n| {
            nodes
                .get(n)
                .copied()
                .ok_or_else(|| format!("node {n} is missing from the extract"))
        })
        .collect()
}

/// The polygons of a multipolygon relation: outer rings with the inner rings inside them.
fn relation_polygons(
    members: &[(i64, String)],
    ways: &HashMap<i64, Vec<i64>>,
    nodes: &HashMap<i64, RawPoint>,
    notes: &mut Vec<String>,
) -> std::result::Result<Vec<RawPolygon>, String> {
    let mut outer = Vec::new();
    let mut inner = Vec::new();
    for (way, role) in members {
        let refs = ways
            .get(way)
            .ok_or_else(|| format!("member way {way} is missing from the extract"))?;
        match role.as_str() {
            "inner" => inner.push(refs.clone()),
            _ => outer.push(refs.clone()),
        }
    }
    let outer = join_rings(outer)?;
    let inner = join_rings(inner)?;
    if outer.is_empty() {
        return Err("no outer ring".into());
    }
    let mut polygons: Vec<RawPolygon> = outer
        .iter()
        .map(|r| ring_points(r, nodes).map(|p| vec![p]))
        .collect::<std::result::Result<_, _>>()?;
    for ring in &inner {
        let points = ring_points(ring, nodes)?;
        let inside = |outer: &[RawPoint]| {
            let outer: Vec<glam::DVec2> =
                outer.iter().map(|p| glam::DVec2::new(p[0], p[1])).collect();
            let centre = points
                .iter()
                .fold(glam::DVec2::ZERO, |s, p| s + glam::DVec2::new(p[0], p[1]))
                / points.len() as f64;
            crate::model::point_in_ring(centre, &outer)
        };
        match polygons.iter_mut().find(|p| inside(&p[0])) {
            Some(polygon) => polygon.push(points),
            None => notes.push("an inner ring outside every outer ring was ignored".into()),
        }
    }
    Ok(polygons)
}

/// Parse an OSM PBF file into buildings.
pub fn parse(bytes: &[u8], name: &str, options: &InputOptions) -> Result<Parsed> {
    if options.metric {
        return Err(Error::input(format!(
            "{name}: --metric does not apply to OSM PBF files (they are always lon/lat)"
        )));
    }
    // Pass 1: building relations, and the ways they need.
    let mut relations = Vec::new();
    each_element(bytes, name, |e| {
        if let Element::Relation(r) = e {
            let tags = collect_tags(r.tags());
            if tags.get("type").map(String::as_str) == Some("multipolygon") && is_building(&tags) {
                let members = r
                    .members()
                    .filter(|m| m.member_type == RelMemberType::Way)
                    .map(|m| (m.member_id, m.role().unwrap_or("").to_string()))
                    .collect();
                relations.push(Feature::Relation {
                    id: r.id(),
                    members,
                    tags,
                });
            }
        }
    })?;
    let member_ways: HashSet<i64> = relations
        .iter()
        .flat_map(|f| match f {
            Feature::Relation { members, .. } => members.iter().map(|m| m.0).collect(),
            Feature::Way { .. } => Vec::new(),
        })
        .collect();
    // Pass 2: building ways and member ways.
    let mut features = Vec::new();
    let mut ways: HashMap<i64, Vec<i64>> = HashMap::new();
    each_element(bytes, name, |e| {
        if let Element::Way(w) = e {
            let tags = collect_tags(w.tags());
            let building = is_building(&tags);
            if building || member_ways.contains(&w.id()) {
                let refs: Vec<i64> = w.refs().collect();
                if member_ways.contains(&w.id()) {
                    ways.insert(w.id(), refs.clone());
                }
                if building {
                    features.push(Feature::Way {
                        id: w.id(),
                        refs,
                        tags,
                    });
                }
            }
        }
    })?;
    features.extend(relations);
    let needed: HashSet<i64> = features
        .iter()
        .filter_map(|f| match f {
            Feature::Way { refs, .. } => Some(refs),
            Feature::Relation { .. } => None,
        })
        .chain(ways.values())
        .flatten()
        .copied()
        .collect();
    // Pass 3: the coordinates of the nodes used.
    let mut nodes: HashMap<i64, RawPoint> = HashMap::with_capacity(needed.len());
    each_element(bytes, name, |e| match e {
        Element::DenseNode(n) if needed.contains(&n.id()) => {
            nodes.insert(n.id(), [n.lon(), n.lat()]);
        }
        Element::Node(n) if needed.contains(&n.id()) => {
            nodes.insert(n.id(), [n.lon(), n.lat()]);
        }
        _ => {}
    })?;

    let mut parsed = Parsed {
        coordinates: Coordinates::LonLat,
        buildings: Vec::new(),
        skipped: Vec::new(),
        features_read: features.len(),
        winding_matters: false,
    };
    for (index, feature) in features.iter().enumerate() {
        let mut notes = Vec::new();
        let polygons = match feature {
            Feature::Way { refs, .. } if refs.len() >= 4 && refs.first() == refs.last() => {
                ring_points(refs, &nodes).map(|ring| vec![vec![ring]])
            }
            Feature::Way { .. } => Err("the building way is not closed".to_string()),
            Feature::Relation { members, .. } => {
                relation_polygons(members, &ways, &nodes, &mut notes)
            }
        };
        let polygons = match polygons {
            Ok(p) => p,
            Err(why) => {
                parsed.skipped.push(Warning {
                    feature: feature.id(),
                    message: format!("{why}; skipped"),
                });
                continue;
            }
        };
        let (height, occludes) = height(feature.tags(), options, &mut notes);
        if let Some(note) = feature
            .tags()
            .get("min_height")
            .and_then(|t| parse_length(t))
            .and_then(|m| super::height::min_height_note(m, height))
        {
            notes.push(note);
        }
        parsed.buildings.push(RawBuilding {
            index,
            id: feature.id(),
            id_given: true,
            polygons,
            height,
            occludes,
            notes,
        });
    }
    Ok(parsed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tags(pairs: &[(&str, &str)]) -> Tags {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn osm_heights() {
        let o = InputOptions::default();
        let mut notes = Vec::new();
        assert_eq!(
            height(&tags(&[("height", "12 m")]), &o, &mut notes),
            (12.0, true)
        );
        let (h, _) = height(&tags(&[("height", "30'")]), &o, &mut notes);
        assert!((h - 9.144).abs() < 1e-9);
        assert_eq!(
            height(
                &tags(&[("building:levels", "4"), ("roof:levels", "1")]),
                &o,
                &mut notes
            ),
            (15.0, true)
        );
        assert_eq!(
            height(
                &tags(&[("height", "20"), ("min_height", "8")]),
                &o,
                &mut notes
            ),
            (20.0, false)
        );
        assert_eq!(
            height(
                &tags(&[("building:min_level", "2"), ("building:levels", "5")]),
                &o,
                &mut notes
            ),
            (15.0, false)
        );
        assert!(notes.is_empty());
        assert_eq!(
            height(
                &tags(&[("height", "tall"), ("building:levels", "2")]),
                &o,
                &mut notes
            ),
            (6.0, true)
        );
        assert_eq!(notes.len(), 1);
        assert_eq!(height(&tags(&[]), &o, &mut notes), (o.default_height, true));
    }

    #[test]
    fn rings_join_in_either_direction() {
        let rings = join_rings(vec![vec![1, 2, 3], vec![5, 4, 3], vec![5, 6, 1]]).unwrap();
        assert_eq!(rings, vec![vec![1, 2, 3, 4, 5, 6, 1]]);
        assert!(join_rings(vec![vec![1, 2, 3], vec![3, 4]]).is_err());
        let two = join_rings(vec![vec![1, 2, 3, 1], vec![7, 8, 9, 7]]).unwrap();
        assert_eq!(two.len(), 2);
    }
}
