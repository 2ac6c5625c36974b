//! `citypvs diff`: what changed between two `.pvs` files, as text or JSON.
//! Exit status 0 when both hold the same cells with the same visible sets,
//! 1 when they differ, 2 on error.

use std::path::PathBuf;

use clap::Args;

use crate::Result;
use crate::pvs::PvsReader;
use crate::scale::diff::diff;

#[derive(Args, Debug)]
pub struct DiffArgs {
    /// The first (old) .pvs file.
    pub a: PathBuf,
    /// The second (new) .pvs file.
    pub b: PathBuf,
    /// Print the difference as one JSON object.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &DiffArgs) -> Result<i32> {
    let a = PvsReader::open(&args.a)?;
    let b = PvsReader::open(&args.b)?;
    let d = diff(&a, &b)?;
    if args.json {
        let mut v = serde_json::to_value(&d).expect("diff serialises");
        v["equal"] = serde_json::Value::Bool(d.is_equal());
        println!("{v}");
    } else {
        println!(
            "{} -> {}: {} cells removed, {} added, {} of {} common cells changed",
            args.a.display(),
            args.b.display(),
            d.cells_removed.len(),
            d.cells_added.len(),
            d.changed.len(),
            d.common_cells
        );
        for h in &d.header_changes {
            println!("header  {h}");
        }
        for id in &d.objects_removed {
            println!("object  - {id}");
        }
        for id in &d.objects_added {
            println!("object  + {id}");
        }
        for c in &d.cells_removed {
            println!("cell    - {c}");
        }
        for c in &d.cells_added {
            println!("cell    + {c}");
        }
        for c in &d.changed {
            let mut parts: Vec<String> = c.gained.iter().map(|id| format!("+{id}")).collect();
            parts.extend(c.lost.iter().map(|id| format!("-{id}")));
            println!("cell    {} -> {}: {}", c.cell_a, c.cell_b, parts.join(" "));
        }
    }
    Ok(if d.is_equal() { 0 } else { 1 })
}
