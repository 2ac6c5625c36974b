//! Build script: a digest of the source of the steps whose results the
//! geometry cache keeps (src/geometry, src/cells, src/model.rs) and of the
//! locked dependencies, as `CITYPVS_GEOMETRY_SOURCE`, so that a cache made
//! by another build of those steps is never taken (docs/DESIGN.md, "The
//! geometry cache").

use std::hash::Hasher;
use std::path::{Path, PathBuf};

fn main() {
    let mut files: Vec<PathBuf> = vec!["src/model.rs".into(), "Cargo.lock".into()];
    for dir in ["src/geometry", "src/cells"] {
        println!("cargo:rerun-if-changed={dir}");
        if let Ok(entries) = std::fs::read_dir(dir) {
            files.extend(entries.flatten().map(|e| e.path()));
        }
    }
    files.sort();
    // FNV-1a over (name, length, bytes) of each file: stable across Rust
    // versions, unlike std's default hasher.
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    for file in &files {
        println!("cargo:rerun-if-changed={}", file.display());
        let bytes = std::fs::read(Path::new(file)).unwrap_or_default();
        h.write(file.to_string_lossy().as_bytes());
        h.write(&(bytes.len() as u64).to_le_bytes());
        h.write(&bytes);
    }
    println!(
        "cargo:rustc-env=CITYPVS_GEOMETRY_SOURCE={:016x}",
        h.finish()
    );
}

struct Fnv(u64);

impl Hasher for Fnv {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
}
