//! `citypvs inspect`: print a `.pvs` file's header and statistics, or dump
//! its cells and visible sets as JSON.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::input::Frame;
use crate::pvs::codec::TAG_NAMES;
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
    eps: f64,
    eye_height: f64,
    pixel: f64,
    max_cell_edge: f64,
    margin: f64,
}

#[derive(Serialize)]
struct StatsJson {
    cells: usize,
    objects: usize,
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
    /// Records per coding, by name.
    record_codings: std::collections::BTreeMap<&'static str, u64>,
}

#[derive(Serialize)]
struct CellJson<'a> {
    index: usize,
    triangle_local: [[f64; 2]; 3],
    triangle_input: [[f64; 2]; 3],
    visible: Vec<&'a str>,
}

#[derive(Serialize)]
struct InspectJson<'a> {
    file: String,
    header: HeaderJson<'a>,
    stats: StatsJson,
    cells: Vec<CellJson<'a>>,
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 { a / b } else { 0.0 }
}

fn header(reader: &PvsReader) -> HeaderJson<'_> {
    let info = reader.info();
    HeaderJson {
        format_version: FORMAT_VERSION,
        tool_version: &info.tool_version,
        source_sha256: info
            .source_hash
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
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
        eps: info.eps,
        eye_height: info.eye_height,
        pixel: info.pixel,
        max_cell_edge: info.max_cell_edge,
        margin: info.margin,
    }
}

fn stats(reader: &PvsReader) -> Result<StatsJson> {
    let sizes = reader.measure()?;
    let counts = (0..reader.cell_count())
        .map(|c| reader.visible(c).map(|v| v.len()))
        .collect::<Result<Vec<_>>>()?;
    let cells = reader.cell_count();
    Ok(StatsJson {
        cells,
        objects: reader.object_ids().len(),
        mean_visible: ratio(counts.iter().sum::<usize>() as f64, cells as f64),
        max_visible: counts.iter().copied().max().unwrap_or(0),
        file_bytes: reader.file_bytes(),
        bytes_per_cell: ratio(reader.file_bytes() as f64, cells as f64),
        record_bytes: sizes.chosen,
        record_bytes_per_cell: ratio(sizes.chosen as f64, cells as f64),
        raw_bitset_bytes: sizes.raw_bitset,
        quake_rle_bytes: sizes.quake_rle,
        compression_vs_raw: ratio(sizes.raw_bitset as f64, sizes.chosen as f64),
        record_codings: TAG_NAMES
            .iter()
            .zip(sizes.tag_counts)
            .map(|(name, n)| (*name, n))
            .collect(),
    })
}

fn cell_json(reader: &PvsReader, index: usize) -> Result<CellJson<'_>> {
    let tri = reader.cell_triangle(index);
    let frame = &reader.info().frame;
    Ok(CellJson {
        index,
        triangle_local: tri.map(|p| [p.x, p.y]),
        triangle_input: tri.map(|p| {
            let (x, y) = frame.to_input(p);
            [x, y]
        }),
        visible: reader.visible_ids(index)?,
    })
}

pub fn run(args: &InspectArgs) -> Result<i32> {
    let reader = PvsReader::open(&args.file)?;
    let name = args.file.display().to_string();
    if let Some(c) = args.cell
        && c >= reader.cell_count()
    {
        return Err(Error::new(format!(
            "{name}: --cell {c} does not exist (the file has {} cells)",
            reader.cell_count()
        )));
    }
    let stats = stats(&reader).map_err(|e| e.context(&name))?;
    let cells = match args.cell {
        Some(c) => vec![c],
        None if args.json => (0..reader.cell_count()).collect(),
        None => Vec::new(),
    };
    let cells = cells
        .into_iter()
        .map(|c| cell_json(&reader, c))
        .collect::<Result<Vec<_>>>()
        .map_err(|e| e.context(&name))?;
    let dump = InspectJson {
        file: name,
        header: header(&reader),
        stats,
        cells,
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&dump).expect("inspect JSON serialises")
        );
    } else {
        print_text(&dump);
    }
    Ok(0)
}

fn print_text(d: &InspectJson) {
    let h = &d.header;
    let s = &d.stats;
    println!("file:         {}", d.file);
    println!(
        "format:       .pvs version {}, written by {}",
        h.format_version, h.tool_version
    );
    println!("input sha256: {}", h.source_sha256);
    println!("frame:        {}", h.frame_description);
    println!(
        "bake:         eps {} m, eye height {} m, pixel {} m, max cell edge {} m, margin {} m",
        h.eps, h.eye_height, h.pixel, h.max_cell_edge, h.margin
    );
    println!("cells:        {}", s.cells);
    println!("objects:      {}", s.objects);
    println!(
        "visible:      mean {:.1}, max {} per cell",
        s.mean_visible, s.max_visible
    );
    println!(
        "file:         {} bytes, {:.1} bytes per cell",
        s.file_bytes, s.bytes_per_cell
    );
    println!(
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
    println!("codings:      {}", codings.join(", "));
    for c in &d.cells {
        println!("cell {}:", c.index);
        let fmt = |t: &[[f64; 2]; 3], digits: usize| {
            t.iter()
                .map(|p| format!("({:.digits$}, {:.digits$})", p[0], p[1]))
                .collect::<Vec<_>>()
                .join(" ")
        };
        println!("  local metres: {}", fmt(&c.triangle_local, 3));
        println!("  input frame:  {}", fmt(&c.triangle_input, 8));
        println!("  visible ({}): {}", c.visible.len(), c.visible.join(" "));
    }
}
