//! The panel under the map: legend entries flowing left to right in rows,
//! and on the first row's right end a scale bar and a north arrow.

use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Rect as SkRect, Stroke, Transform};

use super::font::{draw_text, text_width};
use super::palette::{self, RAMP_STEPS, Ramp, Rgb};

/// How a legend swatch shows its colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mark {
    /// A filled square.
    Fill,
    /// An outlined square.
    Outline,
    /// A dot.
    Dot,
}

/// One legend entry.
#[derive(Clone, Debug)]
pub enum Entry {
    /// A line of text.
    Text(String),
    /// A colour swatch and its label.
    Swatch {
        colour: Rgb,
        mark: Mark,
        label: String,
    },
    /// A colour ramp: label, low-end text, the bar, high-end text.
    Ramp {
        ramp: Ramp,
        label: String,
        low: String,
        high: String,
    },
}

/// Sizes of the panel, all derived from the picture width.
#[derive(Clone, Copy, Debug)]
pub struct Metrics {
    /// Cap height of text in pixels.
    pub text: f32,
    pub row: f32,
    pub pad: f32,
    pub gap: f32,
}

impl Metrics {
    pub fn for_width(width: u32) -> Metrics {
        let text = (width as f32 / 90.0).max(7.0).round();
        Metrics {
            text,
            row: 2.6 * text,
            pad: text,
            gap: 2.2 * text,
        }
    }

    fn swatch(&self) -> f32 {
        1.5 * self.text
    }

    fn ramp_bar(&self) -> f32 {
        10.0 * self.text
    }

    fn inner_gap(&self) -> f32 {
        0.7 * self.text
    }

    fn label_gap(&self) -> f32 {
        1.4 * self.text
    }

    fn entry_width(&self, entry: &Entry) -> f32 {
        let t = self.text;
        match entry {
            Entry::Text(s) => text_width(s, t),
            Entry::Swatch { label, .. } => self.swatch() + self.inner_gap() + text_width(label, t),
            Entry::Ramp {
                label, low, high, ..
            } => {
                text_width(label, t)
                    + self.label_gap()
                    + text_width(low, t)
                    + self.ramp_bar()
                    + text_width(high, t)
                    + 2.0 * self.inner_gap()
            }
        }
    }
}

/// The length of the scale bar in metres (1, 2 or 5 times a power of ten)
/// that is at most `max_pixels` long at `pixels_per_metre`.
pub fn scale_bar_metres(pixels_per_metre: f64, max_pixels: f64) -> f64 {
    let limit = max_pixels / pixels_per_metre;
    let mut power = 10f64.powf(limit.log10().floor());
    if !(power.is_finite() && power > 0.0) {
        power = 1.0;
    }
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&l| l <= limit)
        .unwrap_or(power)
}

fn metres_label(metres: f64) -> String {
    if metres >= 1000.0 {
        format!("{} KM", metres / 1000.0)
    } else if metres >= 1.0 {
        format!("{metres} M")
    } else {
        format!("{:.1} M", metres)
    }
}

/// Where the entries go: (entry index, x, row).
pub struct Layout {
    pub placed: Vec<(usize, f32, usize)>,
    pub rows: usize,
    pub metrics: Metrics,
    pub scale_metres: f64,
}

impl Layout {
    /// Panel height in pixels.
    pub fn height(&self) -> u32 {
        (self.rows as f32 * self.metrics.row + 2.0 * self.metrics.pad).ceil() as u32
    }
}

/// Width kept free on the first row for the scale bar, its label and the arrow.
fn reserved_width(m: &Metrics, scale_metres: f64, pixels_per_metre: f64) -> f32 {
    (scale_metres * pixels_per_metre) as f32
        + m.inner_gap()
        + text_width(&metres_label(scale_metres), m.text)
        + m.gap
        + text_width("N", m.text)
        + m.inner_gap()
        + 1.2 * m.text
        + m.pad
}

/// Place the entries in rows across a panel `width` pixels wide.
pub fn layout(entries: &[Entry], width: u32, pixels_per_metre: f64) -> Layout {
    let m = Metrics::for_width(width);
    let scale_metres = scale_bar_metres(pixels_per_metre, 0.18 * width as f64);
    let reserved = reserved_width(&m, scale_metres, pixels_per_metre);
    let mut placed = Vec::new();
    let (mut x, mut row) = (m.pad, 0usize);
    for (k, entry) in entries.iter().enumerate() {
        let w = m.entry_width(entry);
        let limit = width as f32 - m.pad - if row == 0 { reserved } else { 0.0 };
        if x > m.pad && x + w > limit {
            row += 1;
            x = m.pad;
        }
        placed.push((k, x, row));
        x += w + m.gap;
    }
    Layout {
        placed,
        rows: row + 1,
        metrics: m,
        scale_metres,
    }
}

fn fill_rect(pixmap: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, colour: Rgb) {
    if let Some(r) = SkRect::from_xywh(x, y, w, h) {
        let mut p = Paint::default();
        p.set_color(colour.color());
        p.anti_alias = false;
        pixmap.fill_rect(r, &p, Transform::identity(), None);
    }
}

fn stroke_rect(pixmap: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, colour: Rgb, width: f32) {
    if let Some(r) = SkRect::from_xywh(x, y, w, h) {
        let mut p = Paint::default();
        p.set_color(colour.color());
        p.anti_alias = true;
        let s = Stroke {
            width,
            ..Stroke::default()
        };
        pixmap.stroke_path(
            &PathBuilder::from_rect(r),
            &p,
            &s,
            Transform::identity(),
            None,
        );
    }
}

/// Draw the panel (entries, scale bar, north arrow) with its top at `top`.
pub fn draw(
    pixmap: &mut Pixmap,
    entries: &[Entry],
    layout: &Layout,
    top: f32,
    pixels_per_metre: f64,
) {
    let m = layout.metrics;
    let t = m.text;
    let width = pixmap.width() as f32;
    let line = (t / 10.0).max(1.0);
    fill_rect(pixmap, 0.0, top, width, line, palette::INK);
    // Baseline of each row: text centred vertically in the row.
    let baseline = |row: usize| top + m.pad + row as f32 * m.row + 0.5 * (m.row + t);
    for &(k, x, row) in &layout.placed {
        let y = baseline(row);
        match &entries[k] {
            Entry::Text(s) => draw_text(pixmap, s, x, y, t, palette::INK),
            Entry::Swatch {
                colour,
                mark,
                label,
            } => {
                let s = m.swatch();
                let (sx, sy) = (x, y - 0.5 * t - 0.5 * s);
                match mark {
                    Mark::Fill => {
                        fill_rect(pixmap, sx, sy, s, s, *colour);
                        stroke_rect(pixmap, sx, sy, s, s, palette::BUILDING_OUTLINE, line);
                    }
                    Mark::Outline => stroke_rect(pixmap, sx, sy, s, s, *colour, 2.0 * line),
                    Mark::Dot => {
                        if let Some(c) =
                            PathBuilder::from_circle(sx + 0.5 * s, sy + 0.5 * s, 0.3 * s)
                        {
                            let mut p = Paint::default();
                            p.set_color(colour.color());
                            p.anti_alias = true;
                            pixmap.fill_path(
                                &c,
                                &p,
                                FillRule::Winding,
                                Transform::identity(),
                                None,
                            );
                        }
                    }
                }
                draw_text(pixmap, label, x + s + m.inner_gap(), y, t, palette::INK);
            }
            Entry::Ramp {
                ramp,
                label,
                low,
                high,
            } => {
                let mut cx = x;
                draw_text(pixmap, label, cx, y, t, palette::INK);
                cx += text_width(label, t) + m.label_gap();
                draw_text(pixmap, low, cx, y, t, palette::INK);
                cx += text_width(low, t) + m.inner_gap();
                let bar = m.ramp_bar().round();
                let (by, bh) = ((y - 1.1 * t).round(), (1.2 * t).round());
                let (x0, n) = (cx.round(), RAMP_STEPS as f32);
                for (k, c) in ramp.steps().enumerate() {
                    let a = (x0 + bar * k as f32 / n).round();
                    let b = (x0 + bar * (k + 1) as f32 / n).round();
                    fill_rect(pixmap, a, by, b - a, bh, c);
                }
                cx = x0;
                stroke_rect(pixmap, cx, by, bar, bh, palette::INK, line);
                cx += bar + m.inner_gap();
                draw_text(pixmap, high, cx, y, t, palette::INK);
            }
        }
    }
    // Scale bar and north arrow on the first row's right end.
    let y = baseline(0);
    let arrow_w = 1.2 * t;
    let arrow_x = width - m.pad - arrow_w;
    draw_north_arrow(pixmap, arrow_x, y, arrow_w, t);
    let n_x = arrow_x - m.inner_gap() - text_width("N", t);
    draw_text(pixmap, "N", n_x, y, t, palette::INK);
    let label = metres_label(layout.scale_metres);
    let bar_px = (layout.scale_metres * pixels_per_metre) as f32;
    let label_x = n_x - m.gap - text_width(&label, t);
    let bar_x = label_x - m.inner_gap() - bar_px;
    let (by, bh) = (y - 0.8 * t, 0.6 * t);
    fill_rect(pixmap, bar_x, by, 0.5 * bar_px, bh, palette::INK);
    fill_rect(
        pixmap,
        bar_x + 0.5 * bar_px,
        by,
        0.5 * bar_px,
        bh,
        palette::WHITE,
    );
    stroke_rect(pixmap, bar_x, by, bar_px, bh, palette::INK, line);
    draw_text(pixmap, &label, label_x, y, t, palette::INK);
}

/// An upward arrow `w` wide standing on `baseline`, `t` high.
fn draw_north_arrow(pixmap: &mut Pixmap, x: f32, baseline: f32, w: f32, t: f32) {
    let tip = baseline - 1.3 * t;
    let mut pb = PathBuilder::new();
    pb.move_to(x + 0.5 * w, tip);
    pb.line_to(x + w, baseline + 0.3 * t);
    pb.line_to(x + 0.5 * w, baseline - 0.15 * t);
    pb.line_to(x, baseline + 0.3 * t);
    pb.close();
    if let Some(path) = pb.finish() {
        let mut p = Paint::default();
        p.set_color(palette::INK.color());
        p.anti_alias = true;
        pixmap.fill_path(&path, &p, FillRule::Winding, Transform::identity(), None);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_bar_is_a_round_length_that_fits() {
        assert_eq!(scale_bar_metres(1.0, 288.0), 200.0);
        assert_eq!(scale_bar_metres(2.0, 288.0), 100.0);
        assert_eq!(scale_bar_metres(0.1, 288.0), 2000.0);
        assert_eq!(scale_bar_metres(10.0, 288.0), 20.0);
        assert_eq!(scale_bar_metres(1.0, 50.0), 50.0);
        assert_eq!(metres_label(2000.0), "2 KM");
        assert_eq!(metres_label(50.0), "50 M");
    }

    #[test]
    fn entries_wrap_into_rows_that_fit() {
        let entries: Vec<Entry> = (0..12)
            .map(|i| Entry::Swatch {
                colour: palette::VISIBLE,
                mark: Mark::Fill,
                label: format!("ENTRY NUMBER {i}"),
            })
            .collect();
        let l = layout(&entries, 800, 1.0);
        assert!(l.rows > 1);
        let m = l.metrics;
        for &(k, x, row) in &l.placed {
            let reserved = reserved_width(&m, l.scale_metres, 1.0);
            let limit = 800.0 - m.pad - if row == 0 { reserved } else { 0.0 };
            assert!(x + m.entry_width(&entries[k]) <= limit, "entry {k}");
        }
    }
}
