//! The upper envelope of straight lines over a closed interval of one
//! parameter: the running "horizon" of elevations along one wedge of rays.
//! The envelope of lines is convex, so comparing a line with it (or the
//! envelope with another line) only needs the envelope's breakpoints.

/// A line `value(s) = at0 + slope * s`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    pub at0: f64,
    pub slope: f64,
}

impl Line {
    pub fn at(&self, s: f64) -> f64 {
        self.at0 + self.slope * s
    }
}

/// The maximum of the lines inserted so far over `[lo, hi]`, as pieces.
#[derive(Clone, Debug, Default)]
pub struct Envelope {
    lo: f64,
    hi: f64,
    /// (start of the piece, line on it), starts ascending, the first at `lo`.
    pieces: Vec<(f64, Line)>,
    spare: Vec<(f64, Line)>,
    /// The envelope's smallest value over `[lo, hi]` (at a breakpoint).
    lowest: f64,
}

/// Relative tolerance under which two elevations count as equal (touching).
const RELATIVE_TOLERANCE: f64 = 1e-9;
const ABSOLUTE_TOLERANCE: f64 = 1e-12;

/// The slack allowed when `value` is compared with `bound`: comparisons
/// within it count as touching.
pub fn tolerance(value: f64, bound: f64) -> f64 {
    RELATIVE_TOLERANCE * (value.abs() + bound.abs()) + ABSOLUTE_TOLERANCE
}

impl Envelope {
    /// Forget every line and start over on `[lo, hi]`.
    pub fn reset(&mut self, lo: f64, hi: f64) {
        self.lo = lo;
        self.hi = hi;
        self.pieces.clear();
        self.lowest = f64::NEG_INFINITY;
    }

    pub fn is_empty(&self) -> bool {
        self.pieces.is_empty()
    }

    /// The breakpoints of the envelope (both interval ends included) with its
    /// value there.
    pub fn breakpoints(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        let last = self.pieces.last().map(|&(_, l)| (self.hi, l.at(self.hi)));
        self.pieces.iter().map(|&(s, l)| (s, l.at(s))).chain(last)
    }

    /// Where `line` comes closest to rising above the envelope: the `s` of the
    /// largest `line(s) - envelope(s)`, and that difference. `line` minus the
    /// envelope is concave, so the maximum is at a breakpoint. An empty
    /// envelope gives `(midpoint, +inf)`.
    pub fn best_against(&self, line: &Line) -> (f64, f64) {
        if self.pieces.is_empty() {
            return (0.5 * (self.lo + self.hi), f64::INFINITY);
        }
        let mut best = (self.lo, f64::NEG_INFINITY);
        for (s, m) in self.breakpoints() {
            let v = line.at(s);
            let margin = v - m + tolerance(v, m);
            if margin > best.1 {
                best = (s, margin);
            }
        }
        best
    }

    /// True when the envelope lies strictly above `line` (beyond the touching
    /// tolerance) over the whole interval. The envelope minus a line is
    /// convex, so its minimum is at a breakpoint. Answered at once when the
    /// envelope's lowest value clears the line's highest (at an end).
    pub fn strictly_above(&self, line: &Line) -> bool {
        if self.pieces.is_empty() {
            return false;
        }
        let highest = line.at(self.lo).max(line.at(self.hi));
        if self.lowest - highest > tolerance(highest, self.lowest) {
            return true;
        }
        if self.pieces.len() == 1 {
            // A single line: the two ends decide.
            let l = self.pieces[0].1;
            return [self.lo, self.hi].iter().all(|&s| {
                let (m, v) = (l.at(s), line.at(s));
                m - v > tolerance(v, m)
            });
        }
        self.breakpoints().all(|(s, m)| {
            let v = line.at(s);
            m - v > tolerance(v, m)
        })
    }

    /// Raise the envelope to `max(envelope, line)`.
    pub fn insert(&mut self, line: Line) {
        if self.pieces.is_empty() {
            self.pieces.push((self.lo, line));
            self.lowest = line.at(self.lo).min(line.at(self.hi));
            return;
        }
        let mut out = std::mem::take(&mut self.spare);
        out.clear();
        let push = |out: &mut Vec<(f64, Line)>, s: f64, l: Line| match out.last() {
            Some(&(_, last)) if last == l => {}
            _ => out.push((s, l)),
        };
        for i in 0..self.pieces.len() {
            let (s0, piece) = self.pieces[i];
            let s1 = self.pieces.get(i + 1).map_or(self.hi, |p| p.0);
            let d0 = line.at(s0) - piece.at(s0);
            let d1 = line.at(s1) - piece.at(s1);
            if d0 <= 0.0 && d1 <= 0.0 {
                push(&mut out, s0, piece);
            } else if d0 >= 0.0 && d1 >= 0.0 {
                push(&mut out, s0, line);
            } else {
                let cross = (s0 + (s1 - s0) * d0 / (d0 - d1)).clamp(s0, s1);
                if d0 > 0.0 {
                    push(&mut out, s0, line);
                    if cross < s1 {
                        push(&mut out, cross, piece);
                    }
                } else {
                    push(&mut out, s0, piece);
                    if cross < s1 {
                        push(&mut out, cross, line);
                    }
                }
            }
        }
        self.spare = std::mem::replace(&mut self.pieces, out);
        self.lowest = self
            .breakpoints()
            .map(|(_, m)| m)
            .fold(f64::INFINITY, f64::min);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn max_of(lines: &[Line], s: f64) -> f64 {
        lines
            .iter()
            .map(|l| l.at(s))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    #[test]
    fn envelope_equals_the_pointwise_maximum() {
        let lines = [
            Line {
                at0: 0.0,
                slope: 1.0,
            },
            Line {
                at0: 0.5,
                slope: -1.0,
            },
            Line {
                at0: 0.2,
                slope: 0.0,
            },
            Line {
                at0: -3.0,
                slope: 0.1,
            },
            Line {
                at0: 0.3,
                slope: 0.5,
            },
        ];
        let mut env = Envelope::default();
        env.reset(-1.0, 1.0);
        for (k, l) in lines.iter().enumerate() {
            env.insert(*l);
            for i in 0..=200 {
                let s = -1.0 + i as f64 / 100.0;
                let value = env
                    .pieces
                    .iter()
                    .rev()
                    .find(|p| p.0 <= s)
                    .map(|p| p.1.at(s))
                    .unwrap();
                assert!((value - max_of(&lines[..=k], s)).abs() < 1e-12, "s {s}");
            }
        }
        // Breakpoints: 0.5-s meets 0.3+0.5s at s = 2/15, the flat 0.2 never wins
        // against both, y = s meets 0.3 + 0.5 s at s = 0.6.
        let starts: Vec<f64> = env.pieces.iter().map(|p| p.0).collect();
        assert_eq!(starts.len(), 3, "{starts:?}");
        assert!((starts[1] - 2.0 / 15.0).abs() < 1e-12);
        assert!((starts[2] - 0.6).abs() < 1e-12);
    }

    #[test]
    fn a_line_above_somewhere_is_found() {
        let mut env = Envelope::default();
        env.reset(-1.0, 1.0);
        env.insert(Line {
            at0: 0.0,
            slope: 1.0,
        });
        env.insert(Line {
            at0: 0.0,
            slope: -1.0,
        });
        // |s| envelope; the line 0.1 rises above it only near s = 0.
        let (s, margin) = env.best_against(&Line {
            at0: 0.1,
            slope: 0.0,
        });
        assert!(s.abs() < 1e-12 && margin > 0.0);
        let (_, margin) = env.best_against(&Line {
            at0: -0.1,
            slope: 0.0,
        });
        assert!(margin < 0.0);
        assert!(env.strictly_above(&Line {
            at0: -0.1,
            slope: 0.05
        }));
        assert!(!env.strictly_above(&Line {
            at0: 0.0,
            slope: 0.0
        }));
    }
}
