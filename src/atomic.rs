//! Atomic file output: every file citypvs writes goes to a temporary file in
//! the destination folder first and is renamed into place, so a failed run
//! never leaves a half-written file.

use std::path::{Path, PathBuf};

use crate::Result;

/// Write `contents` to `path` atomically: a temporary file in the same folder, then rename.
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<()> {
    use std::io::Write;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let fail =
        |e: std::io::Error| crate::Error::new(format!("{}: cannot write: {e}", path.display()));
    let mut tmp = tempfile::NamedTempFile::new_in(&dir).map_err(fail)?;
    tmp.write_all(contents).map_err(fail)?;
    tmp.as_file().sync_all().map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}
