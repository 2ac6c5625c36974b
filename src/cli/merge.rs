//! `citypvs merge`: check the shard files of a sharded bake (same input,
//! same settings, every shard once, none truncated or corrupted) and write
//! the `.pvs` file one bake of the whole city writes, byte for byte.

use std::path::PathBuf;

use clap::Args;

use crate::Result;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shard files (`citypvs bake CITY --shard K/N`), all N of them, in any order.
    #[arg(required = true, value_name = "SHARD")]
    pub shards: Vec<PathBuf>,
    /// The .pvs file to write.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Print the summary as one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(serde::Serialize)]
struct Summary {
    output: String,
    shards: usize,
    cells: usize,
    objects: usize,
    file_bytes: u64,
}

pub fn run(args: &MergeArgs) -> Result<i32> {
    let merged = crate::scale::shard::merge_shards(&args.shards, &args.output)?;
    let summary = Summary {
        output: args.output.display().to_string(),
        shards: args.shards.len(),
        cells: merged.cells,
        objects: merged.objects,
        file_bytes: merged.write.file_bytes,
    };
    if args.json {
        println!(
            "{}",
            serde_json::to_string(&summary).expect("summary serialises")
        );
    } else {
        println!(
            "merged {} shards -> {} ({} cells, {} buildings, {} bytes)",
            summary.shards, summary.output, summary.cells, summary.objects, summary.file_bytes
        );
    }
    Ok(0)
}
