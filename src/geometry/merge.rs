//! Grouping occluding buildings whose footprints touch or overlap into
//! blocks, and building each block's height field as nested level areas
//! (docs/METHOD.md §4: never erode wall-sharing buildings one by one).

use geo::Intersects;

use super::convert::{multipolygon_from_geo, multipolygon_to_geo};
use super::{Block, Level};
use crate::model::{Building, Rect, multipolygon_bounds};

/// Group the occluding buildings into blocks of touching footprints and
/// compute each block's levels.
pub fn merge_blocks(buildings: &[Building]) -> Vec<Block> {
    let occluders: Vec<usize> = (0..buildings.len())
        .filter(|&i| buildings[i].occludes && !buildings[i].footprint.is_empty())
        .collect();
    let shapes: Vec<geo::MultiPolygon<f64>> = occluders
        .iter()
        .map(|&i| multipolygon_to_geo(&buildings[i].footprint))
        .collect();
    let bounds: Vec<Rect> = occluders
        .iter()
        .map(|&i| multipolygon_bounds(&buildings[i].footprint))
        .collect();

    let mut groups = UnionFind::new(occluders.len());
    for (a, b) in overlapping_boxes(&bounds) {
        if groups.find(a) != groups.find(b) && shapes[a].intersects(&shapes[b]) {
            groups.union(a, b);
        }
    }

    // Members per group, in ascending building index; groups ordered by their
    // smallest member (the first member, as `occluders` ascends).
    let mut members_of_root: Vec<Vec<usize>> = vec![Vec::new(); occluders.len()];
    let mut order = Vec::new();
    for k in 0..occluders.len() {
        let root = groups.find(k);
        if members_of_root[root].is_empty() {
            order.push(root);
        }
        members_of_root[root].push(k);
    }

    use rayon::prelude::*;
    order
        .par_iter()
        .map(|&root| {
            let local = &members_of_root[root];
            Block {
                members: local.iter().map(|&k| occluders[k]).collect(),
                levels: levels(local, &shapes, |k| buildings[occluders[k]].height),
            }
        })
        .collect()
}

/// The levels of one block: for each distinct member height H (ascending),
/// the union of the member footprints at least H high.
fn levels(
    members: &[usize],
    shapes: &[geo::MultiPolygon<f64>],
    height: impl Fn(usize) -> f64,
) -> Vec<Level> {
    let mut heights: Vec<f64> = members.iter().map(|&k| height(k)).collect();
    heights.sort_by(f64::total_cmp);
    heights.dedup();
    heights
        .into_iter()
        .filter_map(|h| {
            let parts: Vec<&geo::MultiPolygon<f64>> = members
                .iter()
                .filter(|&&k| height(k) >= h)
                .map(|&k| &shapes[k])
                .collect();
            let area = multipolygon_from_geo(&union(&parts), 0.0);
            (!area.is_empty()).then_some(Level { height: h, area })
        })
        .collect()
}

/// The union of valid multipolygons (each counter-clockwise outside,
/// clockwise holes), overlaps and shared walls dissolved.
fn union(parts: &[&geo::MultiPolygon<f64>]) -> geo::MultiPolygon<f64> {
    geo::unary_union(parts.iter().copied())
}

/// All pairs (a, b), a < b, whose closed bounding boxes intersect, in a
/// deterministic order (sweep over x).
fn overlapping_boxes(bounds: &[Rect]) -> Vec<(usize, usize)> {
    let mut by_min_x: Vec<usize> = (0..bounds.len()).collect();
    by_min_x.sort_by(|&a, &b| bounds[a].min.x.total_cmp(&bounds[b].min.x).then(a.cmp(&b)));
    let mut pairs = Vec::new();
    let mut active: Vec<usize> = Vec::new();
    for &i in &by_min_x {
        let x = bounds[i].min.x;
        active.retain(|&j| bounds[j].max.x >= x);
        for &j in &active {
            if bounds[i].intersects(&bounds[j]) {
                pairs.push((i.min(j), i.max(j)));
            }
        }
        active.push(i);
    }
    pairs
}

/// Disjoint sets with path halving and union by size.
struct UnionFind {
    parent: Vec<usize>,
    size: Vec<usize>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind {
            parent: (0..n).collect(),
            size: vec![1; n],
        }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a;
        self.size[a] += self.size[b];
    }
}
