//! The scene model shared by every stage: polygons and buildings in local
//! metres (x east, y north, z up, flat ground at z = 0), and the small
//! polygon predicates every stage needs (area, orientation, point inside).

use glam::DVec2;

/// A polygon ring: its vertices in order, the first NOT repeated at the end.
pub type Ring = Vec<DVec2>;

/// A polygon with holes. Invariant after input repair: the exterior is
/// counter-clockwise, every hole is clockwise, rings have at least three
/// distinct vertices and non-zero area.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Polygon {
    /// Outer boundary, counter-clockwise.
    pub exterior: Ring,
    /// Holes (courtyards), each clockwise.
    pub holes: Vec<Ring>,
}

/// A set of polygons with disjoint interiors.
pub type MultiPolygon = Vec<Polygon>;

/// One input building: a footprint extruded from the ground to `height`.
#[derive(Clone, Debug, PartialEq)]
pub struct Building {
    /// The object id written to the PVS (the input feature's id).
    pub id: String,
    /// Footprint in local metres.
    pub footprint: MultiPolygon,
    /// Height in metres above the ground, > 0.
    pub height: f64,
    /// False for parts lifted off the ground (OSM `min_height` > 0): they are
    /// PVS objects but never occluders.
    pub occludes: bool,
}

/// An axis-aligned rectangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub min: DVec2,
    pub max: DVec2,
}

impl Rect {
    /// The empty rectangle (min = +inf, max = -inf); grows with [`Rect::include`].
    pub const EMPTY: Rect = Rect {
        min: DVec2::splat(f64::INFINITY),
        max: DVec2::splat(f64::NEG_INFINITY),
    };

    /// Grow to contain `p`.
    pub fn include(&mut self, p: DVec2) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest rectangle containing all points.
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a DVec2>) -> Rect {
        let mut r = Rect::EMPTY;
        for p in points {
            r.include(*p);
        }
        r
    }

    /// True when no point was included.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y
    }

    /// Grown by `margin` on every side.
    pub fn grown(&self, margin: f64) -> Rect {
        Rect {
            min: self.min - DVec2::splat(margin),
            max: self.max + DVec2::splat(margin),
        }
    }

    /// The union of two rectangles.
    pub fn union(&self, other: &Rect) -> Rect {
        Rect {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// True when `p` lies in the closed rectangle.
    pub fn contains_point(&self, p: DVec2) -> bool {
        self.min.x <= p.x && p.x <= self.max.x && self.min.y <= p.y && p.y <= self.max.y
    }

    /// True when the closed rectangles share a point.
    pub fn intersects(&self, other: &Rect) -> bool {
        self.min.x <= other.max.x
            && other.min.x <= self.max.x
            && self.min.y <= other.max.y
            && other.min.y <= self.max.y
    }

    pub fn width(&self) -> f64 {
        self.max.x - self.min.x
    }

    pub fn height(&self) -> f64 {
        self.max.y - self.min.y
    }
}

/// Twice the signed area of a ring: positive when counter-clockwise.
pub fn ring_signed_area2(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    let mut sum = 0.0;
    for i in 0..n {
        let a = ring[i];
        let b = ring[(i + 1) % n];
        sum += a.perp_dot(b);
    }
    sum
}

/// Area of a polygon (exterior minus holes).
pub fn polygon_area(polygon: &Polygon) -> f64 {
    let outer = ring_signed_area2(&polygon.exterior).abs();
    let holes: f64 = polygon
        .holes
        .iter()
        .map(|h| ring_signed_area2(h).abs())
        .sum();
    0.5 * (outer - holes)
}

/// Area of a multipolygon.
pub fn multipolygon_area(mp: &[Polygon]) -> f64 {
    mp.iter().map(polygon_area).sum()
}

/// Even-odd point-in-ring test (boundary points may go either way).
pub fn point_in_ring(p: DVec2, ring: &[DVec2]) -> bool {
    let mut inside = false;
    ring_crossings(ring, p.y, |x| {
        if p.x < x {
            inside = !inside;
        }
    });
    inside
}

/// Call `f` with the x of every crossing of the horizontal line at `y` with
/// the sides of `ring` (a side crosses when exactly one of its ends lies
/// above the line): `p` with `p.y == y` is inside the ring when an odd
/// number of them lie beyond `p.x`. [`point_in_ring`] is this count, so a
/// row of points sharing one `y` can take the crossings once, bit for bit.
pub fn ring_crossings(ring: &[DVec2], y: f64, mut f: impl FnMut(f64)) {
    let n = ring.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let a = ring[i];
        let b = ring[j];
        if (a.y > y) != (b.y > y) {
            f(a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y));
        }
        j = i;
    }
}

/// True when `p` lies inside the polygon (inside the exterior, outside every hole).
pub fn point_in_polygon(p: DVec2, polygon: &Polygon) -> bool {
    point_in_ring(p, &polygon.exterior) && !polygon.holes.iter().any(|h| point_in_ring(p, h))
}

/// True when `p` lies inside any polygon of the multipolygon.
pub fn point_in_multipolygon(p: DVec2, mp: &[Polygon]) -> bool {
    mp.iter().any(|poly| point_in_polygon(p, poly))
}

/// Distance from `p` to the segment `a`-`b`: the square root of
/// [`squared_distance_to_segment`] (so the least of several distances is,
/// bit for bit, the root of the least square: a correctly rounded square
/// root is monotone).
pub fn distance_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    squared_distance_to_segment(p, a, b).sqrt()
}

/// The square of the distance from `p` to the segment `a`-`b`.
#[inline]
pub fn squared_distance_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((a + ab * t) - p).length_squared()
}

/// The fewest equal pieces (at least one) the segment from `a` to `b` can
/// be cut into so that none is longer than `max_piece`.
pub fn piece_count(a: DVec2, b: DVec2, max_piece: f64) -> usize {
    let len = a.distance(b);
    let mut n = (len / max_piece).ceil().max(1.0) as usize;
    if len / n as f64 > max_piece {
        n += 1;
    }
    n
}

/// The `n + 1` points that cut the segment from `a` to `b` into `n` equal
/// pieces, in order: `a` and `b` exactly at the ends, `a + (b - a) k / n`
/// between. The one way every stage splits a segment.
pub fn cut_points(a: DVec2, b: DVec2, n: usize) -> impl Iterator<Item = DVec2> {
    (0..=n).map(move |k| match k {
        0 => a,
        k if k == n => b,
        k => a + (b - a) * (k as f64 / n as f64),
    })
}

/// Iterate over the edges `(a, b)` of a ring, closing it.
pub fn ring_edges(ring: &[DVec2]) -> impl Iterator<Item = (DVec2, DVec2)> + '_ {
    let n = ring.len();
    (0..n).map(move |i| (ring[i], ring[(i + 1) % n]))
}

/// Iterate over every edge of every ring of a polygon.
pub fn polygon_edges(polygon: &Polygon) -> impl Iterator<Item = (DVec2, DVec2)> + '_ {
    std::iter::once(&polygon.exterior)
        .chain(polygon.holes.iter())
        .flat_map(|r| ring_edges(r))
}

/// Bounding rectangle of a multipolygon's exteriors.
pub fn multipolygon_bounds(mp: &[Polygon]) -> Rect {
    Rect::of_points(mp.iter().flat_map(|p| p.exterior.iter()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, s: f64) -> Ring {
        vec![
            DVec2::new(x0, y0),
            DVec2::new(x0 + s, y0),
            DVec2::new(x0 + s, y0 + s),
            DVec2::new(x0, y0 + s),
        ]
    }

    #[test]
    fn area_and_orientation_of_a_square_with_a_hole() {
        let mut hole = square(1.0, 1.0, 1.0);
        hole.reverse();
        let p = Polygon {
            exterior: square(0.0, 0.0, 4.0),
            holes: vec![hole],
        };
        assert!(ring_signed_area2(&p.exterior) > 0.0);
        assert!((polygon_area(&p) - 15.0).abs() < 1e-12);
        assert!(point_in_polygon(DVec2::new(3.0, 3.0), &p));
        assert!(!point_in_polygon(DVec2::new(1.5, 1.5), &p));
        assert!(!point_in_polygon(DVec2::new(5.0, 1.5), &p));
    }

    #[test]
    fn segment_distance() {
        let d = distance_to_segment(DVec2::new(0.5, 2.0), DVec2::ZERO, DVec2::X);
        assert!((d - 2.0).abs() < 1e-12);
        let d = distance_to_segment(DVec2::new(3.0, 0.0), DVec2::ZERO, DVec2::X);
        assert!((d - 2.0).abs() < 1e-12);
    }
}
