//! Cell-to-object visibility: samples on each cell's top edges, software cull
//! maps of the shrunk occluders' shadows, the hierarchical horizon test, and
//! the per-cell potentially visible sets (METHOD.md 3 to 6).
