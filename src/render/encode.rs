//! PNG encoding of a finished picture: an 8-bit palette image, which keeps
//! city maps small. A picture of at most 256 colours is stored exactly.
//! Otherwise (anti-aliased blends along edges) the palette is the colours
//! the caller requires (the flat map colours and ramp steps), the most
//! frequent other colours and a coarse colour cube, and each pixel takes
//! the nearest entry.

use std::collections::HashMap;

use tiny_skia::Pixmap;

use super::palette::Rgb;

use crate::{Error, Result};

type Rgb8 = [u8; 3];

/// Levels per channel of the colour cube that bounds every pixel's error.
const CUBE_LEVELS: u8 = 4;

fn distance2(a: Rgb8, b: Rgb8) -> u32 {
    a.iter()
        .zip(b.iter())
        .map(|(&x, &y)| (x as i32 - y as i32).pow(2) as u32)
        .sum()
}

/// The palette and each pixel's index into it.
fn quantise(pixmap: &Pixmap, required: &[Rgb]) -> (Vec<Rgb8>, Vec<u8>) {
    let rgb: Vec<Rgb8> = pixmap
        .pixels()
        .iter()
        .map(|p| {
            let c = p.demultiply();
            [c.red(), c.green(), c.blue()]
        })
        .collect();
    // Hash maps only count and look up; the palette is sorted, so the
    // output does not depend on their order.
    let mut counts: HashMap<Rgb8, u64> = HashMap::new();
    for c in &rgb {
        *counts.entry(*c).or_insert(0) += 1;
    }
    let mut by_count: Vec<(Rgb8, u64)> = counts.iter().map(|(c, n)| (*c, *n)).collect();
    by_count.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    let palette: Vec<Rgb8> = if by_count.len() <= 256 {
        by_count.iter().map(|(c, _)| *c).collect()
    } else {
        let step = 255 / (CUBE_LEVELS - 1);
        let levels = (0..CUBE_LEVELS).map(|l| l * step);
        let cube: Vec<Rgb8> = levels
            .clone()
            .flat_map(|r| {
                let levels = levels.clone();
                levels.flat_map(move |g| (0..CUBE_LEVELS).map(move |b| [r, g, b * step]))
            })
            .collect();
        let mut palette: Vec<Rgb8> = Vec::with_capacity(256);
        for c in required.iter().map(|c| [c.0, c.1, c.2]) {
            if !palette.contains(&c) && !cube.contains(&c) && palette.len() + cube.len() < 256 {
                palette.push(c);
            }
        }
        let room = 256 - cube.len() - palette.len();
        let frequent: Vec<Rgb8> = by_count
            .iter()
            .map(|(c, _)| *c)
            .filter(|c| !cube.contains(c) && !palette.contains(c))
            .take(room)
            .collect();
        palette.extend(frequent);
        palette.extend(cube);
        palette
    };
    let index_of: HashMap<Rgb8, u8> = counts
        .keys()
        .map(|c| {
            let best = (0..palette.len())
                .min_by_key(|&i| (distance2(*c, palette[i]), i))
                .unwrap_or(0);
            (*c, best as u8)
        })
        .collect();
    let indices = rgb.iter().map(|c| index_of[c]).collect();
    (palette, indices)
}

/// The picture as PNG bytes (8-bit palette, best compression); the
/// `required` colours are kept exactly.
pub fn encode_png(pixmap: &Pixmap, required: &[Rgb]) -> Result<Vec<u8>> {
    let (palette, indices) = quantise(pixmap, required);
    let fail = |e: png::EncodingError| Error::io(format!("cannot encode the picture as PNG: {e}"));
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, pixmap.width(), pixmap.height());
        encoder.set_color(png::ColorType::Indexed);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_palette(palette.concat());
        encoder.set_compression(png::Compression::Best);
        encoder.set_filter(png::FilterType::NoFilter);
        encoder.set_adaptive_filter(png::AdaptiveFilterType::NonAdaptive);
        let mut writer = encoder.write_header().map_err(fail)?;
        writer.write_image_data(&indices).map_err(fail)?;
        writer.finish().map_err(fail)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiny_skia::{Color, Paint, Rect, Transform};

    #[test]
    fn few_colours_survive_exactly_and_many_map_to_the_nearest() {
        let mut pm = Pixmap::new(64, 32).unwrap();
        pm.fill(Color::from_rgba8(250, 250, 246, 255));
        let mut paint = Paint::default();
        paint.set_color(Color::from_rgba8(242, 142, 43, 255));
        pm.fill_rect(
            Rect::from_xywh(0.0, 0.0, 10.0, 10.0).unwrap(),
            &paint,
            Transform::identity(),
            None,
        );
        let png = encode_png(&pm, &[]).unwrap();
        let back = Pixmap::decode_png(&png).unwrap();
        assert_eq!(back.data(), pm.data());
        // A gradient of 64 * 32 reds and greens: more than 256 colours.
        for y in 0..32u32 {
            for x in 0..64u32 {
                let c =
                    tiny_skia::PremultipliedColorU8::from_rgba(x as u8 * 4, y as u8 * 8, 0, 255)
                        .unwrap();
                pm.pixels_mut()[(y * 64 + x) as usize] = c;
            }
        }
        let rare = Rgb(4, 8, 0);
        let back = Pixmap::decode_png(&encode_png(&pm, &[rare]).unwrap()).unwrap();
        for (a, b) in pm.pixels().iter().zip(back.pixels()) {
            let (a, b) = (a.demultiply(), b.demultiply());
            let (a, b) = (
                [a.red(), a.green(), a.blue()],
                [b.red(), b.green(), b.blue()],
            );
            assert!(distance2(a, b) <= 3 * 43 * 43, "{a:?} -> {b:?}");
            if a == [rare.0, rare.1, rare.2] {
                assert_eq!(a, b, "a required colour is kept exactly");
            }
        }
    }
}
