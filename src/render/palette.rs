//! The colours of every picture: flat colours for map features and the
//! colour ramps for building heights, cull-map shadow heights and PVS sizes.

/// An opaque sRGB colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// As a tiny-skia colour with the given opacity (0 to 1).
    pub fn with_alpha(self, alpha: f32) -> tiny_skia::Color {
        tiny_skia::Color::from_rgba8(
            self.0,
            self.1,
            self.2,
            (alpha.clamp(0.0, 1.0) * 255.0) as u8,
        )
    }

    /// As an opaque tiny-skia colour.
    pub fn color(self) -> tiny_skia::Color {
        self.with_alpha(1.0)
    }

    /// Straight linear blend: `t = 0` gives `self`, `t = 1` gives `other`.
    pub fn mix(self, other: Rgb, t: f64) -> Rgb {
        let t = t.clamp(0.0, 1.0);
        let channel = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * t).round() as u8;
        Rgb(
            channel(self.0, other.0),
            channel(self.1, other.1),
            channel(self.2, other.2),
        )
    }
}

/// Map area outside every view cell (inside buildings' gaps outside the region).
pub const OUTSIDE: Rgb = Rgb(226, 226, 220);
/// Free space covered by view cells.
pub const FREE_SPACE: Rgb = Rgb(250, 250, 246);
/// View-cell outlines.
pub const CELL_OUTLINE: Rgb = Rgb(150, 150, 150);
/// The chosen cell's fill.
pub const CHOSEN_CELL: Rgb = Rgb(214, 39, 153);
/// Buildings in the chosen cell's PVS.
pub const VISIBLE: Rgb = Rgb(242, 142, 43);
/// Buildings culled from the chosen cell's PVS.
pub const CULLED: Rgb = Rgb(200, 200, 200);
/// Buildings when the cells carry the PVS-size heat map.
pub const NEUTRAL_BUILDING: Rgb = Rgb(96, 96, 96);
/// Building outlines.
pub const BUILDING_OUTLINE: Rgb = Rgb(60, 60, 60);
/// Shrunk occluder outlines (cull-map layer).
pub const OCCLUDER_OUTLINE: Rgb = Rgb(20, 20, 20);
/// Free space dropped as narrower than the minimum gap.
pub const DROPPED: Rgb = Rgb(220, 30, 30);
/// Sample points.
pub const SAMPLE: Rgb = Rgb(0, 0, 0);
/// Text, scale bar and north arrow.
pub const INK: Rgb = Rgb(30, 30, 30);
/// The legend panel under the map.
pub const PANEL: Rgb = Rgb(255, 255, 255);
/// White, for halos and scale-bar segments.
pub const WHITE: Rgb = Rgb(255, 255, 255);

/// The flat colours of map features and the panel.
pub const FLAT: [Rgb; 14] = [
    OUTSIDE,
    FREE_SPACE,
    CELL_OUTLINE,
    CHOSEN_CELL,
    VISIBLE,
    CULLED,
    NEUTRAL_BUILDING,
    BUILDING_OUTLINE,
    OCCLUDER_OUTLINE,
    SAMPLE,
    INK,
    PANEL,
    WHITE,
    Rgb(0, 0, 0),
];

/// Ramps are drawn in this many steps: a picture then has few colours, all
/// of them in its PNG palette exactly, and each step is told apart.
pub const RAMP_STEPS: usize = 32;

/// A colour ramp: evenly spaced stops, linear in between.
#[derive(Clone, Copy, Debug)]
pub struct Ramp(pub &'static [Rgb]);

impl Ramp {
    /// The colour of the step that `t` in 0..=1 (clamped) falls in: the
    /// ramp at the nearest of [`RAMP_STEPS`] evenly spaced points.
    pub fn step(&self, t: f64) -> Rgb {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let last = (RAMP_STEPS - 1) as f64;
        self.at((t * last).round() / last)
    }

    /// Every step's colour, low to high.
    pub fn steps(&self) -> impl Iterator<Item = Rgb> + '_ {
        (0..RAMP_STEPS).map(|k| self.at(k as f64 / (RAMP_STEPS - 1) as f64))
    }

    /// The colour at `t` in 0..=1 (clamped).
    pub fn at(&self, t: f64) -> Rgb {
        let stops = self.0;
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let x = t * (stops.len() - 1) as f64;
        let i = (x.floor() as usize).min(stops.len() - 2);
        stops[i].mix(stops[i + 1], x - i as f64)
    }
}

/// Building heights: light (low) to dark (tall).
pub const HEIGHT_RAMP: Ramp = Ramp(&[
    Rgb(236, 226, 204),
    Rgb(196, 170, 132),
    Rgb(140, 105, 80),
    Rgb(74, 52, 50),
]);

/// Cull-map shadow heights: pale blue (low) to deep blue (high).
pub const CULL_RAMP: Ramp = Ramp(&[
    Rgb(198, 219, 239),
    Rgb(107, 174, 214),
    Rgb(33, 113, 181),
    Rgb(8, 48, 107),
]);

/// PVS sizes: dark purple (few) through teal to yellow (many).
pub const PVS_RAMP: Ramp = Ramp(&[
    Rgb(68, 1, 84),
    Rgb(59, 82, 139),
    Rgb(33, 145, 140),
    Rgb(94, 201, 98),
    Rgb(253, 231, 37),
]);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_hits_its_stops_and_clamps() {
        let stops = PVS_RAMP.0;
        assert_eq!(PVS_RAMP.at(0.0), stops[0]);
        assert_eq!(PVS_RAMP.at(1.0), stops[stops.len() - 1]);
        assert_eq!(PVS_RAMP.at(0.5), stops[2]);
        assert_eq!(PVS_RAMP.at(-3.0), stops[0]);
        assert_eq!(PVS_RAMP.at(7.0), stops[stops.len() - 1]);
        assert_eq!(PVS_RAMP.at(f64::NAN), stops[0]);
    }

    #[test]
    fn steps_are_the_only_colours_step_gives() {
        let steps: Vec<Rgb> = CULL_RAMP.steps().collect();
        assert_eq!(steps.len(), RAMP_STEPS);
        assert_eq!(steps[0], CULL_RAMP.at(0.0));
        assert_eq!(steps[RAMP_STEPS - 1], CULL_RAMP.at(1.0));
        for k in 0..=1000 {
            let t = k as f64 / 1000.0;
            let c = CULL_RAMP.step(t);
            let i = steps.iter().position(|s| *s == c).expect("a step colour");
            let centre = i as f64 / (RAMP_STEPS - 1) as f64;
            assert!((t - centre).abs() <= 0.5 / (RAMP_STEPS - 1) as f64 + 1e-12);
        }
    }
}
