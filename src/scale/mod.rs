//! Bakes that outgrow one machine or one run: shards (a bake split into N
//! contiguous, cost-balanced ranges of cells, baked by separate processes
//! and merged into the bytes one bake writes), checkpoints (a bake that is
//! killed picks up where it stopped), and the difference between two
//! `.pvs` files. See docs/scale-out.md.
//!
//! Submodules: [`part`] (the shard and checkpoint file), [`shard`] (which
//! shard, the split, the merge), [`resume`] (the checkpointed bake of a
//! range), [`rebake`] (the incremental bake from a previous file), [`diff`]
//! (comparing two `.pvs` files), [`geometry_cache`] (the file of shrunk
//! levels and opened tiles that an edited city's preparation takes from).

pub mod diff;
pub mod geometry_cache;
pub mod part;
pub mod rebake;
pub mod resume;
pub mod sealed;
pub mod shard;
