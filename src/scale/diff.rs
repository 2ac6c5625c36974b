//! What changed between two `.pvs` files: cells removed and added (cells
//! are matched by their triangles, bit for bit), and for every cell in both
//! the buildings gained and lost (matched by object id), plus the header
//! fields that differ.

use std::collections::{BTreeSet, HashMap};

use crate::Result;
use crate::pvs::PvsReader;

/// One cell in both files whose visible set differs.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CellChange {
    /// The cell's index in the first and in the second file.
    pub cell_a: usize,
    pub cell_b: usize,
    /// Object ids visible in the second file but not in the first.
    pub gained: Vec<String>,
    /// Object ids visible in the first file but not in the second.
    pub lost: Vec<String>,
}

/// The difference between two files.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PvsDiff {
    pub cells_a: usize,
    pub cells_b: usize,
    /// Cells in both files.
    pub common_cells: usize,
    /// Indices (in the first file) of cells not in the second.
    pub cells_removed: Vec<usize>,
    /// Indices (in the second file) of cells not in the first.
    pub cells_added: Vec<usize>,
    /// Common cells whose sets differ, in the first file's cell order.
    pub changed: Vec<CellChange>,
    /// Object ids only in the first / only in the second file.
    pub objects_removed: Vec<String>,
    pub objects_added: Vec<String>,
    /// Header fields that differ (settings, input hash, frame, tool version).
    pub header_changes: Vec<String>,
}

impl PvsDiff {
    /// Both files hold the same cells with the same visible sets (by id).
    /// Header fields are reported but do not count.
    pub fn is_equal(&self) -> bool {
        self.cells_removed.is_empty() && self.cells_added.is_empty() && self.changed.is_empty()
    }
}

/// A cell's identity across files: its corners' exact coordinate bits.
pub(crate) fn cell_key(t: &[glam::DVec2; 3]) -> [u64; 6] {
    [
        t[0].x.to_bits(),
        t[0].y.to_bits(),
        t[1].x.to_bits(),
        t[1].y.to_bits(),
        t[2].x.to_bits(),
        t[2].y.to_bits(),
    ]
}

/// Compare two opened files.
pub fn diff(a: &PvsReader, b: &PvsReader) -> Result<PvsDiff> {
    let mut out = PvsDiff {
        cells_a: a.cell_count(),
        cells_b: b.cell_count(),
        ..PvsDiff::default()
    };
    let (ia, ib) = (a.info(), b.info());
    // The files were checked when opened, so their settings are valid.
    let (sa, sb) = (ia.settings(None)?, ib.settings(None)?);
    for (name, x, y) in sa.changed(&sb) {
        out.header_changes.push(format!("{name}: {x} -> {y}"));
    }
    if ia.source_hash != ib.source_hash {
        out.header_changes.push("input (SHA-256)".into());
    }
    if ia.frame != ib.frame {
        out.header_changes.push("frame".into());
    }
    if ia.tool_version != ib.tool_version {
        out.header_changes.push(format!(
            "tool version: {} -> {}",
            ia.tool_version, ib.tool_version
        ));
    }
    let ids_a: BTreeSet<&str> = a.object_ids().iter().map(String::as_str).collect();
    let ids_b: BTreeSet<&str> = b.object_ids().iter().map(String::as_str).collect();
    out.objects_removed = ids_a.difference(&ids_b).map(|s| s.to_string()).collect();
    out.objects_added = ids_b.difference(&ids_a).map(|s| s.to_string()).collect();

    let mut in_b: HashMap<[u64; 6], usize> = HashMap::with_capacity(b.cell_count());
    for (i, t) in b.cell_triangles().iter().enumerate() {
        in_b.entry(cell_key(t)).or_insert(i);
    }
    let mut matched_b = vec![false; b.cell_count()];
    for (ca, t) in a.cell_triangles().iter().enumerate() {
        let Some(&cb) = in_b.get(&cell_key(t)) else {
            out.cells_removed.push(ca);
            continue;
        };
        if std::mem::replace(&mut matched_b[cb], true) {
            // A duplicate triangle in the first file: not a common cell.
            out.cells_removed.push(ca);
            continue;
        }
        out.common_cells += 1;
        let sa: BTreeSet<&str> = a.visible_ids(ca)?.into_iter().collect();
        let sb: BTreeSet<&str> = b.visible_ids(cb)?.into_iter().collect();
        if sa != sb {
            out.changed.push(CellChange {
                cell_a: ca,
                cell_b: cb,
                gained: sb.difference(&sa).map(|s| s.to_string()).collect(),
                lost: sa.difference(&sb).map(|s| s.to_string()).collect(),
            });
        }
    }
    out.cells_added = (0..b.cell_count()).filter(|&i| !matched_b[i]).collect();
    Ok(out)
}
