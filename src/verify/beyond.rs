//! How high anything can stand beyond a distance, in a range of directions
//! from one viewpoint: the bound that lets the judge stop a ray's walk once
//! its horizon is above everything the rest of its wedge can hold.
//!
//! The directions around the viewpoint are cut into [`SECTORS`] equal
//! sectors. Each building is listed in every sector its directions can meet
//! (widened by a sector on each side), with its farthest vertex distance and
//! its height; within a sector the list is sorted by distance and carries
//! the greatest height of the entries from there on. The buildings are
//! sorted by distance once and dealt out to their sectors in that order, so
//! each sector's list comes out sorted. A building whose
//! vertices do not fit in a half turn (the viewpoint inside its convex
//! hull) is listed in every sector.

use std::f64::consts::{PI, TAU};

use super::buckets::{Buckets, sort_in_buckets};

/// Sectors per turn.
const SECTORS: usize = 256;

/// Per sector, the buildings that reach into it, by distance.
#[derive(Debug, Default)]
pub struct HeightsBeyond {
    /// Sector `s` holds entries `starts[s]..starts[s + 1]`.
    starts: Vec<u32>,
    /// Each entry's farthest distance, ascending within a sector.
    distances: Vec<f64>,
    /// Each entry's greatest height of itself and every later entry of its
    /// sector.
    heights: Vec<f64>,
    /// While building: (first sector, last sector, distance, height), the
    /// sectors counted on past the turn.
    spans: Vec<(i64, i64, f64, f64)>,
    /// While building: where each sector's next entry goes.
    next: Vec<u32>,
    /// Working memory of the spans' sort.
    by_distance: Buckets<(i64, i64, f64, f64)>,
}

/// The sector of azimuth `a` (radians), not wrapped into one turn.
fn sector_of(a: f64) -> i64 {
    ((a + PI) / TAU * SECTORS as f64).floor() as i64
}

impl HeightsBeyond {
    /// Starts a new viewpoint.
    pub fn clear(&mut self) {
        self.spans.clear();
    }

    /// Lists a building of `height` whose vertices have the azimuths
    /// `azimuths` (radians, from the viewpoint) and lie at most `farthest`
    /// from it. `None` for an azimuth: a vertex at the viewpoint itself.
    pub fn add(&mut self, azimuths: impl Iterator<Item = Option<f64>>, farthest: f64, height: f64) {
        let mut reference = None;
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        let mut everywhere = false;
        for a in azimuths {
            let Some(a) = a else {
                everywhere = true;
                break;
            };
            let r = *reference.get_or_insert(a);
            // The angle from the first vertex's direction, in (-pi, pi].
            let mut d = a - r;
            if d > PI {
                d -= TAU;
            } else if d <= -PI {
                d += TAU;
            }
            lo = lo.min(d);
            hi = hi.max(d);
        }
        let Some(r) = reference else {
            return;
        };
        // Vertices within less than a half turn lie in an open half plane
        // through the viewpoint, so the building's points (in their convex
        // hull) lie in the same arc; otherwise any direction may meet it.
        if everywhere || hi - lo >= PI - 1e-6 {
            self.spans.push((0, SECTORS as i64 - 1, farthest, height));
        } else {
            self.spans.push((
                sector_of(r + lo) - 1,
                sector_of(r + hi) + 1,
                farthest,
                height,
            ));
        }
    }

    /// Sorts the lists once every building is added.
    pub fn finish(&mut self) {
        // A span is all sectors or under half a turn plus three sectors, so
        // no building is listed twice in one sector.
        self.starts.clear();
        self.starts.resize(SECTORS + 1, 0);
        for &(first, last, _, _) in &self.spans {
            for k in first..=last {
                self.starts[k.rem_euclid(SECTORS as i64) as usize + 1] += 1;
            }
        }
        for s in 0..SECTORS {
            self.starts[s + 1] += self.starts[s];
        }
        let farthest = self.spans.iter().map(|s| s.2).fold(0.0, f64::max);
        sort_in_buckets(
            &mut self.spans,
            |s| s.2,
            (0.0, farthest),
            &mut self.by_distance,
        );
        let entries = self.starts[SECTORS] as usize;
        self.distances.clear();
        self.distances.resize(entries, 0.0);
        self.heights.clear();
        self.heights.resize(entries, 0.0);
        self.next.clear();
        self.next.extend_from_slice(&self.starts[..SECTORS]);
        for &(first, last, distance, height) in &self.spans {
            for k in first..=last {
                let s = k.rem_euclid(SECTORS as i64) as usize;
                self.distances[self.next[s] as usize] = distance;
                self.heights[self.next[s] as usize] = height;
                self.next[s] += 1;
            }
        }
        for s in 0..SECTORS {
            let list = &mut self.heights[self.starts[s] as usize..self.starts[s + 1] as usize];
            for i in (0..list.len().saturating_sub(1)).rev() {
                list[i] = list[i].max(list[i + 1]);
            }
        }
    }

    /// The greatest height of the buildings listed in a sector the
    /// directions from azimuth `from` to `to` (`to` >= `from`, at most a
    /// turn later) meet, that reach at least `distance` from the viewpoint;
    /// `None` when there are none. (The buildings' sectors are widened, so
    /// the directions' own are not.)
    pub fn highest(&self, from: f64, to: f64, distance: f64) -> Option<f64> {
        let (first, last) = (sector_of(from), sector_of(to));
        let last = last.min(first + SECTORS as i64 - 1);
        let mut highest: Option<f64> = None;
        for k in first..=last {
            let s = k.rem_euclid(SECTORS as i64) as usize;
            let (start, end) = (self.starts[s] as usize, self.starts[s + 1] as usize);
            let i = start + self.distances[start..end].partition_point(|&d| d < distance);
            if i < end {
                let h = self.heights[i];
                highest = Some(highest.map_or(h, |m| m.max(h)));
            }
        }
        highest
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use proptest::prelude::*;

    proptest! {
        /// Every point of a polygon, seen from anywhere, lies in a sector
        /// its building is listed in, and `highest` over directions holding
        /// that point finds a height at least the building's.
        #[test]
        fn every_point_of_a_building_is_in_its_sectors(
            origin in (-50.0f64..50.0, -50.0f64..50.0),
            corners in prop::collection::vec((-40.0f64..40.0, -40.0f64..40.0), 3..8),
            t in prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 1..20),
            height in 1.0f64..60.0,
        ) {
            let o = DVec2::new(origin.0, origin.1);
            let vs: Vec<DVec2> = corners.iter().map(|&(x, y)| DVec2::new(x, y)).collect();
            let azimuth = |p: DVec2| {
                let d = p - o;
                (d.length_squared() > 1e-24).then(|| d.y.atan2(d.x))
            };
            let farthest = vs.iter().map(|v| v.distance(o)).fold(0.0, f64::max);
            let mut beyond = HeightsBeyond::default();
            beyond.clear();
            beyond.add(vs.iter().map(|&v| azimuth(v)), farthest, height);
            beyond.finish();
            // Points in the triangles fanned from the first corner cover
            // the convex hull's fan, hence the polygon.
            for (k, &(u, w)) in t.iter().enumerate() {
                let (a, b, c) = (vs[0], vs[1 + k % (vs.len() - 2)], vs[2 + k % (vs.len() - 2)]);
                let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
                let p = a + (b - a) * u + (c - a) * w;
                let Some(az) = azimuth(p) else { continue };
                let found = beyond.highest(az, az, p.distance(o).min(farthest));
                prop_assert!(found.is_some_and(|h| h >= height), "{p} from {o}: {found:?}");
            }
        }

        /// With many buildings, `highest` is the greatest height of those
        /// listed in the directions' sectors that reach the distance, as a
        /// scan of every listing finds it.
        #[test]
        fn highest_is_the_greatest_height_that_reaches_the_distance(
            buildings in prop::collection::vec(
                (prop::collection::vec(-PI..PI, 1..5), 0.0f64..500.0, 1.0f64..80.0),
                1..60,
            ),
            from in -PI..PI,
            width in 0.0f64..TAU,
            distance in 0.0f64..520.0,
        ) {
            let mut beyond = HeightsBeyond::default();
            beyond.clear();
            for (azimuths, farthest, height) in &buildings {
                beyond.add(azimuths.iter().map(|&a| Some(a)), *farthest, *height);
            }
            beyond.finish();
            let to = from + width;
            let (first, last) = (sector_of(from), sector_of(to).min(sector_of(from) + SECTORS as i64 - 1));
            let wanted: Vec<usize> = (first..=last).map(|k| k.rem_euclid(SECTORS as i64) as usize).collect();
            let scan = beyond
                .spans
                .iter()
                .filter(|&&(f, l, d, _)| {
                    d >= distance
                        && (f..=l).any(|k| wanted.contains(&(k.rem_euclid(SECTORS as i64) as usize)))
                })
                .map(|s| s.3)
                .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))));
            prop_assert_eq!(beyond.highest(from, to, distance), scan);
        }
    }
}
