//! Parsing height and level tags: "12", "12 m", "12.5", "40 ft", "40'",
//! numbers, and level counts, into metres. Shared by every format.

/// Metres per foot.
const METRES_PER_FOOT: f64 = 0.3048;
/// Metres per inch.
const METRES_PER_INCH: f64 = 0.0254;
/// Heights above this are taken as a mistake in the data.
pub const MAX_HEIGHT: f64 = 1000.0;

/// A height written as text: a number with an optional unit ("m", "metres",
/// "ft", "feet", "'", or feet and inches as `12'6"`). Returns metres, or
/// `None` when the text is not a length.
pub fn parse_length(text: &str) -> Option<f64> {
    let t = text.trim();
    if let Some((feet, rest)) = t.split_once('\'') {
        let feet = parse_number(feet)?;
        let rest = rest.trim();
        let inches = if rest.is_empty() {
            0.0
        } else {
            parse_number(rest.strip_suffix('"')?)?
        };
        return Some(feet * METRES_PER_FOOT + inches * METRES_PER_INCH);
    }
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == '+'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value = parse_number(number)?;
    match unit.trim().to_ascii_lowercase().as_str() {
        "" | "m" | "meter" | "meters" | "metre" | "metres" => Some(value),
        "ft" | "feet" | "foot" => Some(value * METRES_PER_FOOT),
        _ => None,
    }
}

/// A plain decimal number (no unit); `None` for anything else.
pub fn parse_number(text: &str) -> Option<f64> {
    let t = text.trim();
    if t.is_empty() {
        return None;
    }
    t.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Whether a height in metres is usable: positive and at most [`MAX_HEIGHT`].
pub fn check_height(height: f64) -> std::result::Result<f64, String> {
    if !height.is_finite() {
        Err(format!("height {height} is not a number"))
    } else if height <= 0.0 {
        Err(format!("height {height} m is not positive"))
    } else if height > MAX_HEIGHT {
        Err(format!(
            "height {height} m is absurd (more than {MAX_HEIGHT} m)"
        ))
    } else {
        Ok(height)
    }
}

/// The warning for a lifted part whose bottom (`min_height`) is not below
/// its top (`height`): it is kept as an object that does not occlude (the
/// conservative reading: nothing is hidden behind it), from the ground to
/// its height like every lifted part.
pub fn min_height_note(min_height: f64, height: f64) -> Option<String> {
    (min_height >= height).then(|| {
        format!(
            "min_height {min_height} m is not below height {height} m: kept as a part that does not occlude"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_with_units() {
        assert_eq!(parse_length("12"), Some(12.0));
        assert_eq!(parse_length(" 12 m"), Some(12.0));
        assert_eq!(parse_length("12.5"), Some(12.5));
        assert_eq!(parse_length("12.5m"), Some(12.5));
        assert!((parse_length("10 ft").unwrap() - 3.048).abs() < 1e-12);
        assert!((parse_length("10'").unwrap() - 3.048).abs() < 1e-12);
        assert!((parse_length("10'6\"").unwrap() - 3.2004).abs() < 1e-12);
        assert_eq!(parse_length("tall"), None);
        assert_eq!(parse_length("12 storeys"), None);
        assert_eq!(parse_length(""), None);
        assert_eq!(parse_length("NaN"), None);
    }

    #[test]
    fn height_limits() {
        assert!(check_height(0.0).is_err());
        assert!(check_height(-3.0).is_err());
        assert!(check_height(1000.5).is_err());
        assert_eq!(check_height(30.0), Ok(30.0));
    }
}
