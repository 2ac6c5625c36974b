//! Fuzz target: the judge's wedges cut only as far as their walks reach
//! must give the verdicts of one wedge between every two neighbouring
//! vertex directions. A scene of up to 24 rotated rectangles (overlapping
//! allowed, some lifted parts that hide nothing) and up to 8 viewpoints is
//! read from the bytes; each viewpoint is judged with the first cuts out to
//! 0 m, 4 m, the default and infinity, and any difference in what is seen
//! (or in whether the viewpoint is inside a building) panics, so the fuzzer
//! keeps the input.
//!
//! Bytes: one count byte (buildings = 1 + its low 5 bits, up to 24), then
//! per building 7 bytes: centre x and y (signed, metres), half length and
//! half width (eighths of a metre, at least 0.25 m), angle (256ths of a half
//! turn), height (quarters of a metre, at least 0.25 m) and a flag byte
//! (bit 0: a lifted part); the rest in groups of 3 bytes are viewpoints:
//! x and y (signed, metres, times 1.3 to fall off the grid of the centres)
//! and height (tenths of a metre).
#![no_main]

use citypvs::model::{Building, Polygon};
use citypvs::verify::{Judge, Scratch, View};
use glam::{DVec2, DVec3};
use libfuzzer_sys::fuzz_target;

fn scene(bytes: &[u8]) -> Option<(Vec<Building>, &[u8])> {
    let (&count, mut rest) = bytes.split_first()?;
    let count = 1 + usize::from(count & 31).min(23);
    let mut city = Vec::new();
    for k in 0..count {
        let (b, tail) = rest.split_at_checked(7)?;
        rest = tail;
        let centre = DVec2::new(f64::from(b[0] as i8), f64::from(b[1] as i8));
        let half = DVec2::new(f64::from(b[2].max(2)) / 8.0, f64::from(b[3].max(2)) / 8.0);
        let angle = f64::from(b[4]) / 256.0 * std::f64::consts::PI;
        let (s, c) = angle.sin_cos();
        let corner = |x: f64, y: f64| centre + DVec2::new(x * c - y * s, x * s + y * c);
        city.push(Building {
            id: format!("b{k}"),
            footprint: vec![Polygon {
                exterior: vec![
                    corner(-half.x, -half.y),
                    corner(half.x, -half.y),
                    corner(half.x, half.y),
                    corner(-half.x, half.y),
                ],
                holes: vec![],
            }],
            height: f64::from(b[5].max(1)) / 4.0,
            occludes: b[6] & 1 == 0,
        });
    }
    Some((city, rest))
}

fn seen(judge: &Judge, p: DVec3, scratch: &mut Scratch) -> Option<Vec<u32>> {
    match judge.view(p, scratch) {
        View::Seen { sightings, .. } => Some(sightings.iter().map(|s| s.building).collect()),
        View::InsideBuilding { .. } => None,
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((city, rest)) = scene(data) else {
        return;
    };
    let every = Judge::new(&city).with_first_cuts_within(f64::INFINITY);
    let others = [
        Judge::new(&city).with_first_cuts_within(0.0),
        Judge::new(&city).with_first_cuts_within(4.0),
        Judge::new(&city),
    ];
    let mut scratch = Scratch::default();
    for v in rest.chunks_exact(3).take(8) {
        let p = DVec3::new(
            f64::from(v[0] as i8) * 1.3,
            f64::from(v[1] as i8) * 1.3,
            f64::from(v[2]) / 10.0,
        );
        let want = seen(&every, p, &mut scratch);
        for judge in &others {
            let got = seen(judge, p, &mut scratch);
            assert_eq!(got, want, "from {p}");
        }
    }
});
