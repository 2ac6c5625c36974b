//! OpenStreetMap PBF extracts: closed ways and multipolygon relations
//! tagged `building=*` or `building:part=*`, their rings assembled from
//! member ways, heights from `height` / `building:levels` / `roof:levels`,
//! and lifted parts (`min_height`, `building:min_level`) kept as objects
//! that do not occlude. Ids are `"w<way id>"` and `"r<relation id>"`.
//!
//! A PBF file is compressed, so a small hostile file can decode to a
//! thousand times its size: what is kept from it is bounded by the file's
//! size (`Budget`), only the tags read are copied, and a panic inside the
//! PBF decoder becomes an error (`guarded`).

use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::io::Cursor;
use std::panic::{AssertUnwindSafe, catch_unwind};

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
        /// Member ways: id, and whether its role is `inner`.
        members: Vec<(i64, bool)>,
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

/// The keys of the tags citypvs reads; every other tag is passed over.
const KEYS_READ: [&str; 8] = [
    "building",
    "building:part",
    "building:levels",
    "building:min_level",
    "height",
    "min_height",
    "roof:levels",
    "type",
];

/// Longest tag value copied; a longer one (no height, level count or
/// building type is anywhere near it) is kept as a note of its length,
/// which reads as a building type that is neither `no` nor open-sided and
/// as a length or number that does not parse.
const MAX_VALUE_BYTES: usize = 256;

/// The tags of [`KEYS_READ`] (the last of a repeated key wins).
fn collect_tags<'a>(tags: impl Iterator<Item = (&'a str, &'a str)>) -> Tags {
    let mut kept = Tags::new();
    for (k, v) in tags {
        if KEYS_READ.contains(&k) {
            let value = if v.len() <= MAX_VALUE_BYTES {
                v.to_string()
            } else {
                format!("({} bytes, not read)", v.len())
            };
            kept.insert(k.to_string(), value);
        }
    }
    kept
}

/// Run `f` over every element, turning reader errors (and panics of the
/// reader, see [`guarded`]) into one clear message.
fn each_element(bytes: &[u8], name: &str, f: impl FnMut(Element<'_>)) -> Result<()> {
    let corrupt = |why: String| {
        Error::input(format!(
            "{name}: the OSM PBF file is truncated or corrupt ({why})"
        ))
    };
    guarded(|| ElementReader::new(Cursor::new(bytes)).for_each(f))
        .map_err(corrupt)?
        .map_err(|e| corrupt(e.to_string()))
}

thread_local! {
    /// Set while [`guarded`] runs on this thread: its panics are caught
    /// and reported as errors, so the panic hook stays quiet about them.
    static GUARDED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Run `f`, turning a panic into `Err` with the panic's message. The PBF
/// decoder panics on some malformed input (a relation member whose type
/// is not one of the format's three, for one); a corrupt file must give an
/// error, not end the process. The first call installs a panic hook that
/// stays silent for panics caught here and hands every other panic to the
/// hook that was there before.
fn guarded<T>(f: impl FnOnce() -> T) -> std::result::Result<T, String> {
    static QUIET_HOOK: std::sync::Once = std::sync::Once::new();
    QUIET_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !GUARDED.with(|g| g.get()) {
                previous(info);
            }
        }));
    });
    let was = GUARDED.with(|g| g.replace(true));
    let result = catch_unwind(AssertUnwindSafe(f));
    GUARDED.with(|g| g.set(was));
    result.map_err(|panic| {
        let message = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "the decoder failed".to_string());
        format!("the PBF decoder failed: {message}")
    })
}

/// How many node references and relation members a file may make the
/// reader keep, per byte of the file. A real extract keeps well under one
/// per byte (every reference costs at least a byte of compressed data);
/// a decompression bomb, or a relation listing one long way a million
/// times, would keep thousands.
const REFERENCES_PER_BYTE: usize = 16;

/// The least [`Budget`], whatever the file's size.
const MIN_REFERENCES: usize = 1 << 20;

/// What the reader may still keep of a file: node references of building
/// ways and member ways, relation members, and the nodes of assembled
/// relation rings, counted together.
struct Budget<'n> {
    name: &'n str,
    limit: usize,
    left: usize,
}

impl<'n> Budget<'n> {
    fn new(name: &'n str, file_bytes: usize) -> Self {
        let limit = file_bytes
            .saturating_mul(REFERENCES_PER_BYTE)
            .max(MIN_REFERENCES);
        Budget {
            name,
            limit,
            left: limit,
        }
    }

    /// Take `n` references from the budget, or the error that refuses the file.
    fn take(&mut self, n: usize) -> Result<()> {
        self.left = self.left.checked_sub(n).ok_or_else(|| {
            Error::input(format!(
                "{}: the OSM PBF file's buildings hold more than {} node references and relation members \
                 ({} per byte of the file): it is corrupt or made to exhaust memory",
                self.name, self.limit, REFERENCES_PER_BYTE
            ))
        })?;
        Ok(())
    }
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
/// A ring starts with the first piece left and goes on with the first piece
/// left that starts or ends where it ends (turned round if it ends there).
fn join_rings(mut pieces: Vec<Vec<i64>>) -> std::result::Result<Vec<Vec<i64>>, String> {
    pieces.retain(|p| p.len() >= 2);
    // The pieces left that start or end at each node, by their order.
    let mut at_node: HashMap<i64, BTreeSet<usize>> = HashMap::new();
    for (i, piece) in pieces.iter().enumerate() {
        for end in [piece[0], piece[piece.len() - 1]] {
            at_node.entry(end).or_default().insert(i);
        }
    }
    // Take piece `i` (left empty, which marks it used) out of the lists.
    let take = |i: usize, pieces: &mut [Vec<i64>], at_node: &mut HashMap<i64, BTreeSet<usize>>| {
        let piece = std::mem::take(&mut pieces[i]);
        for end in [piece[0], piece[piece.len() - 1]] {
            if let Some(set) = at_node.get_mut(&end) {
                set.remove(&i);
            }
        }
        piece
    };
    let mut rings = Vec::new();
    for start in 0..pieces.len() {
        if pieces[start].is_empty() {
            continue;
        }
        let mut ring = take(start, &mut pieces, &mut at_node);
        while ring.first() != ring.last() {
            let end = ring[ring.len() - 1];
            let next = at_node.get(&end).and_then(|set| set.first().copied());
            let Some(i) = next else {
                return Err(format!("a ring does not close (it ends at node {end})"));
            };
            let mut piece = take(i, &mut pieces, &mut at_node);
            if piece[0] != end {
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
/// `Ok(Err(why))` skips the relation; `Err` refuses the file.
fn relation_polygons(
    members: &[(i64, bool)],
    ways: &HashMap<i64, Vec<i64>>,
    nodes: &HashMap<i64, RawPoint>,
    (notes, budget): (&mut Vec<String>, &mut Budget),
) -> Result<std::result::Result<Vec<RawPolygon>, String>> {
    let mut outer = Vec::new();
    let mut inner = Vec::new();
    for &(way, is_inner) in members {
        let Some(refs) = ways.get(&way) else {
            return Ok(Err(format!("member way {way} is missing from the extract")));
        };
        budget.take(refs.len())?;
        if is_inner {
            inner.push(refs.clone());
        } else {
            outer.push(refs.clone());
        }
    }
    Ok(assemble_rings(outer, inner, nodes, notes))
}

/// Most inner rings times outer rings' points that a relation may ask to
/// be tested against each other (each inner ring is placed in the first
/// outer ring holding its centre): real relations ask for a few thousand.
const MAX_RING_TESTS: usize = 100_000_000;

/// The polygons of outer and inner member ways: closed rings of node ids,
/// each inner ring put in the outer ring that holds its centre.
fn assemble_rings(
    outer: Vec<Vec<i64>>,
    inner: Vec<Vec<i64>>,
    nodes: &HashMap<i64, RawPoint>,
    notes: &mut Vec<String>,
) -> std::result::Result<Vec<RawPolygon>, String> {
    let outer = join_rings(outer)?;
    let inner = join_rings(inner)?;
    if outer.is_empty() {
        return Err("no outer ring".into());
    }
    let outer_points: usize = outer.iter().map(Vec::len).sum();
    if inner.len().saturating_mul(outer_points) > MAX_RING_TESTS {
        return Err(format!(
            "{} inner rings in outer rings of {outer_points} nodes are too many to place",
            inner.len()
        ));
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
    let mut budget = Budget::new(name, bytes.len());
    // The first error met inside a pass (the passes' closures cannot
    // return one): the rest of that pass keeps nothing.
    let mut failed: Option<Error> = None;
    // Pass 1: building relations, and the ways they need.
    let mut relations = Vec::new();
    each_element(bytes, name, |e| {
        let Element::Relation(r) = e else { return };
        if failed.is_some() {
            return;
        }
        let tags = collect_tags(r.tags());
        if tags.get("type").map(String::as_str) != Some("multipolygon") || !is_building(&tags) {
            return;
        }
        let mut members = Vec::new();
        let read = guarded(|| {
            for m in r.members() {
                budget.take(1)?;
                if m.member_type == RelMemberType::Way {
                    members.push((m.member_id, m.role().is_ok_and(|role| role == "inner")));
                }
            }
            Ok(())
        });
        match read {
            Ok(Ok(())) => relations.push(Feature::Relation {
                id: r.id(),
                members,
                tags,
            }),
            Ok(Err(e)) => failed = Some(e),
            Err(why) => {
                failed = Some(Error::input(format!(
                    "{name}: relation {} is corrupt: {why}",
                    r.id()
                )))
            }
        }
    })?;
    if let Some(e) = failed.take() {
        return Err(e);
    }
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
        let Element::Way(w) = e else { return };
        if failed.is_some() {
            return;
        }
        let tags = collect_tags(w.tags());
        let building = is_building(&tags);
        let member = member_ways.contains(&w.id());
        if !building && !member {
            return;
        }
        let copies = usize::from(building) + usize::from(member);
        if let Err(e) = budget.take(w.raw_refs().len().saturating_mul(copies)) {
            failed = Some(e);
            return;
        }
        let refs: Vec<i64> = w.refs().collect();
        if member {
            ways.insert(w.id(), refs.clone());
        }
        if building {
            features.push(Feature::Way {
                id: w.id(),
                refs,
                tags,
            });
        }
    })?;
    if let Some(e) = failed {
        return Err(e);
    }
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
                relation_polygons(members, &ways, &nodes, (&mut notes, &mut budget))?
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

    /// The joining by a search of every piece left, as the reader did it
    /// before the index of end nodes: the rings (and the error) it gives
    /// are those `join_rings` must give.
    fn join_rings_by_search(
        mut pieces: Vec<Vec<i64>>,
    ) -> std::result::Result<Vec<Vec<i64>>, String> {
        pieces.retain(|p| p.len() >= 2);
        let mut rings = Vec::new();
        pieces.reverse();
        while let Some(mut ring) = pieces.pop() {
            while ring.first() != ring.last() {
                let end = ring[ring.len() - 1];
                let Some(i) = pieces
                    .iter()
                    .rposition(|p| p.first() == Some(&end) || p.last() == Some(&end))
                else {
                    return Err(format!("a ring does not close (it ends at node {end})"));
                };
                let mut piece = pieces.remove(i);
                if piece[0] != end {
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

    proptest::proptest! {
        /// Rings cut into pieces (some turned round, shuffled, some
        /// pieces dropped, node ids from a small range so that rings
        /// share nodes) join as the search joins them.
        #[test]
        fn joining_by_end_nodes_matches_the_search(
            rings in proptest::collection::vec(proptest::collection::vec(0i64..12, 2..9), 1..5),
            cuts in proptest::collection::vec(1usize..4, 8),
            flips in proptest::collection::vec(proptest::bool::ANY, 40),
            order in proptest::collection::vec(0usize..1000, 40),
            drop in proptest::option::of(0usize..40),
        ) {
            let mut pieces = Vec::new();
            for (r, nodes) in rings.iter().enumerate() {
                let mut ring = nodes.clone();
                ring.push(nodes[0]);
                let step = cuts[r % cuts.len()];
                let mut at = 0;
                while at + 1 < ring.len() {
                    let end = (at + step).min(ring.len() - 1);
                    pieces.push(ring[at..=end].to_vec());
                    at = end;
                }
            }
            for (i, piece) in pieces.iter_mut().enumerate() {
                if flips[i % flips.len()] {
                    piece.reverse();
                }
            }
            let mut keyed: Vec<(usize, Vec<i64>)> = pieces
                .into_iter()
                .enumerate()
                .map(|(i, p)| (order[i % order.len()] * 64 + i, p))
                .collect();
            keyed.sort();
            let mut pieces: Vec<Vec<i64>> = keyed.into_iter().map(|(_, p)| p).collect();
            if let Some(d) = drop.filter(|&d| d < pieces.len()) {
                pieces.remove(d);
            }
            proptest::prop_assert_eq!(join_rings(pieces.clone()), join_rings_by_search(pieces));
        }
    }
}
