//! `citypvs inspect`: print a `.pvs` file's header and statistics, or dump
//! its cells and visible sets as JSON. Statistics are gathered cell by cell
//! and the JSON cells are written one at a time, so memory stays a small
//! multiple of the file whatever its sets hold; text output escapes control
//! characters in ids and strings.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::input::Frame;
use crate::pvs::blocks::CODING_NAMES;
use crate::pvs::codec::zero_rle_len;
use crate::pvs::{FORMAT_VERSION, PvsReader};
use crate::{Error, Result};

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// The .pvs file.
    pub file: PathBuf,
    /// Only this cell (0-based index).
    #[arg(long, value_name = "N")]
    pub cell: Option<usize>,
    /// Print everything as one JSON object: header, statistics and, per cell,
    /// its triangle (local metres and input frame) and visible ids.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum FrameJson<'a> {
    LonLat {
        lon0: f64,
        lat0: f64,
    },
    Metric {
        origin: [f64; 2],
        crs: Option<&'a str>,
    },
}

#[derive(Serialize)]
struct HeaderJson<'a> {
    format_version: u32,
    tool_version: &'a str,
    source_sha256: String,
    frame: FrameJson<'a>,
    frame_description: String,
    /// eps, pixel, eye_height, max_cell_edge, margin, near_field, min_gap.
    #[serde(flatten)]
    numbers: crate::BakeNumbers,
    /// SHA-256 of the region polygon, or null when the bake had no region.
    region_sha256: Option<String>,
}

#[derive(Serialize)]
struct StatsJson {
    cells: usize,
    objects: usize,
    vertices: usize,
    cells_per_block: usize,
    mean_visible: f64,
    max_visible: usize,
    file_bytes: u64,
    bytes_per_cell: f64,
    record_bytes: u64,
    record_bytes_per_cell: f64,
    raw_bitset_bytes: u64,
    quake_rle_bytes: u64,
    /// raw bitset bytes / record bytes.
    compression_vs_raw: f64,
    /// Cells per coding mode, by name.
    record_codings: std::collections::BTreeMap<&'static str, u64>,
}

#[derive(Serialize)]
struct CellJson<'a> {
    index: usize,
    triangle_local: [[f64; 2]; 3],
    triangle_input: [[f64; 2]; 3],
    visible: Vec<&'a str>,
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn header(reader: &PvsReader) -> HeaderJson<'_> {
    let info = reader.info();
    HeaderJson {
        format_version: FORMAT_VERSION,
        tool_version: &info.tool_version,
        source_sha256: hex(&info.source_hash),
        frame: match &info.frame {
            Frame::LonLat { lon0, lat0 } => FrameJson::LonLat {
                lon0: *lon0,
                lat0: *lat0,
            },
            Frame::Metric { origin, crs } => FrameJson::Metric {
                origin: [origin.x, origin.y],
                crs: crs.as_deref(),
            },
        },
        frame_description: info.frame.describe(),
        numbers: info.numbers,
        region_sha256: (info.region_hash != [0; 32]).then(|| hex(&info.region_hash)),
    }
}

fn stats(reader: &PvsReader) -> Result<StatsJson> {
    let cells = reader.cell_count();
    let n = reader.object_ids().len();
    let (mut total, mut max, mut quake) = (0usize, 0usize, 0u64);
    let mut modes = [0u64; 3];
    reader.for_each_visible_mode(|_, set, mode| {
        total += set.len();
        max = max.max(set.len());
        quake += zero_rle_len(set, n);
        modes[(mode as usize).min(2)] += 1;
        Ok(())
    })?;
    let raw = (cells * n.div_ceil(8)) as u64;
    let records = reader.block_bytes();
    Ok(StatsJson {
        cells,
        objects: n,
        vertices: reader.vertex_count(),
        cells_per_block: reader.block_cells(),
        mean_visible: ratio(total as f64, cells as f64),
        max_visible: max,
        file_bytes: reader.file_bytes(),
        bytes_per_cell: ratio(reader.file_bytes() as f64, cells as f64),
        record_bytes: records,
        record_bytes_per_cell: ratio(records as f64, cells as f64),
        raw_bitset_bytes: raw,
        quake_rle_bytes: quake,
        compression_vs_raw: ratio(raw as f64, records as f64),
        record_codings: CODING_NAMES.iter().copied().zip(modes).collect(),
    })
}

fn cell_json<'a>(reader: &'a PvsReader, index: usize, visible: &[u32]) -> CellJson<'a> {
    let tri = reader.cell_triangle(index);
    let frame = &reader.info().frame;
    CellJson {
        index,
        triangle_local: tri.map(|p| [p.x, p.y]),
        triangle_input: tri.map(|p| {
            let (x, y) = frame.to_input(p);
            [x, y]
        }),
        visible: visible
            .iter()
            .map(|&i| reader.object_ids()[i as usize].as_str())
            .collect(),
    }
}

pub fn run(args: &InspectArgs) -> Result<i32> {
    let reader = PvsReader::open(&args.file)?;
    let name = args.file.display().to_string();
    if let Some(c) = args.cell
        && c >= reader.cell_count()
    {
        return Err(Error::usage(format!(
            "{name}: --cell {c} does not exist (the file has {} cells)",
            reader.cell_count()
        )));
    }
    let stats = stats(&reader).map_err(|e| e.context(&name))?;
    let header = header(&reader);
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    let write = |out: &mut dyn std::io::Write, text: &str| {
        out.write_all(text.as_bytes())
            .map_err(|e| Error::io(format!("cannot write the output: {e}")))
    };
    let json = |v: &dyn erased::Json| v.to_json();
    if args.json {
        write(
            &mut out,
            &format!(
                "{{\"file\":{},\"header\":{},\"stats\":{},\"cells\":[",
                json(&name),
                json(&header),
                json(&stats)
            ),
        )?;
        let mut first = true;
        let mut emit = |out: &mut dyn std::io::Write, c: usize, set: &[u32]| -> Result<()> {
            let sep = if first { "" } else { "," };
            first = false;
            write(out, sep)?;
            write(out, &json(&cell_json(&reader, c, set)))
        };
        match args.cell {
            Some(c) => {
                let set = reader.visible(c).map_err(|e| e.context(&name))?;
                emit(&mut out, c, &set)?;
            }
            None => reader
                .for_each_visible(|c, set| emit(&mut out, c, set))
                .map_err(|e| e.context(&name))?,
        }
        write(&mut out, "]}\n")?;
    } else {
        print_text(&mut out, &name, &header, &stats)?;
        if let Some(c) = args.cell {
            let set = reader.visible(c).map_err(|e| e.context(&name))?;
            print_cell(&mut out, &cell_json(&reader, c, &set))?;
        }
    }
    std::io::Write::flush(&mut out)
        .map_err(|e| Error::io(format!("cannot write the output: {e}")))?;
    Ok(0)
}

mod erased {
    /// Serialise anything `Serialize` to a JSON string through a trait object.
    pub trait Json {
        fn to_json(&self) -> String;
    }
    impl<T: serde::Serialize + ?Sized> Json for T {
        fn to_json(&self) -> String {
            serde_json::to_string(self).expect("inspect JSON serialises")
        }
    }
}

/// `s` with control characters escaped (`\n`, `\u{1b}`, ...), so that an id
/// cannot move the cursor or recolour the terminal.
pub fn escape_controls(s: &str) -> std::borrow::Cow<'_, str> {
    if !s.chars().any(char::is_control) {
        return std::borrow::Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for ch in s.chars() {
        if ch.is_control() {
            out.extend(ch.escape_default());
        } else {
            out.push(ch);
        }
    }
    std::borrow::Cow::Owned(out)
}

fn print_text(
    out: &mut dyn std::io::Write,
    file: &str,
    h: &HeaderJson,
    s: &StatsJson,
) -> Result<()> {
    let e = escape_controls;
    let mut text = String::new();
    use std::fmt::Write as _;
    let _ = writeln!(text, "file:         {}", e(file));
    let _ = writeln!(
        text,
        "format:       .pvs version {}, written by {}",
        h.format_version,
        e(h.tool_version)
    );
    let _ = writeln!(text, "input sha256: {}", h.source_sha256);
    let _ = writeln!(
        text,
        "region:       {}",
        h.region_sha256
            .as_deref()
            .map_or("none".to_string(), |r| format!("sha256 {r}"))
    );
    let _ = writeln!(text, "frame:        {}", e(&h.frame_description));
    let _ = writeln!(
        text,
        "bake:         eps {} m, eye height {} m, pixel {} m, max cell edge {} m, margin {} m, near field {} m, min gap {} m",
        h.numbers.eps,
        h.numbers.eye_height,
        h.numbers.pixel,
        h.numbers.max_cell_edge,
        h.numbers.margin,
        h.numbers.near_field,
        h.numbers.min_gap
    );
    let _ = writeln!(
        text,
        "cells:        {} ({} vertices, {} cells per block)",
        s.cells, s.vertices, s.cells_per_block
    );
    let _ = writeln!(text, "objects:      {}", s.objects);
    let _ = writeln!(
        text,
        "visible:      mean {:.1}, max {} per cell",
        s.mean_visible, s.max_visible
    );
    let _ = writeln!(
        text,
        "file:         {} bytes, {:.1} bytes per cell",
        s.file_bytes, s.bytes_per_cell
    );
    let _ = writeln!(
        text,
        "records:      {} bytes, {:.1} per cell; raw bitsets would take {} ({:.1}x), Quake zero-RLE {}",
        s.record_bytes,
        s.record_bytes_per_cell,
        s.raw_bitset_bytes,
        s.compression_vs_raw,
        s.quake_rle_bytes
    );
    let codings: Vec<String> = s
        .record_codings
        .iter()
        .map(|(k, v)| format!("{k} {v}"))
        .collect();
    let _ = writeln!(text, "codings:      {}", codings.join(", "));
    out.write_all(text.as_bytes())
        .map_err(|e| Error::io(format!("cannot write the output: {e}")))
}

fn print_cell(out: &mut dyn std::io::Write, c: &CellJson) -> Result<()> {
    let fmt = |t: &[[f64; 2]; 3], digits: usize| {
        t.iter()
            .map(|p| format!("({:.digits$}, {:.digits$})", p[0], p[1]))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let ids: Vec<_> = c.visible.iter().map(|id| escape_controls(id)).collect();
    let text = format!(
        "cell {}:\n  local metres: {}\n  input frame:  {}\n  visible ({}): {}\n",
        c.index,
        fmt(&c.triangle_local, 3),
        fmt(&c.triangle_input, 8),
        c.visible.len(),
        ids.join(" ")
    );
    out.write_all(text.as_bytes())
        .map_err(|e| Error::io(format!("cannot write the output: {e}")))
}
