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
    let mut builder = tempfile::Builder::new();
    // Like a plain create: readable by others as the umask allows (a
    // temporary file would otherwise be private to its owner).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut tmp = builder.tempfile_in(&dir).map_err(fail)?;
    tmp.write_all(contents).map_err(fail)?;
    tmp.as_file().sync_all().map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_files_get_the_permissions_of_a_plain_create() {
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        let atomic = dir.path().join("atomic");
        std::fs::write(&plain, b"x").unwrap();
        write_atomically(&atomic, b"x").unwrap();
        assert_eq!(std::fs::read(&atomic).unwrap(), b"x");
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions();
        assert_eq!(mode(&atomic), mode(&plain));
    }
}
