//! File output: every file citypvs writes goes through [`write_atomically`].
//!
//! The rules (see docs/guide.md, "Output files"):
//! - a regular file or a new path is written atomically: a temporary file
//!   `.NAME.citypvs-tmp-PID-XXXXXXXX` in the same folder, synced, then renamed
//!   over NAME, so a failed or killed run never leaves a half-written NAME;
//!   stale temporary files of the same output left by a killed run are
//!   removed by the next run;
//! - a symbolic link is followed: its target is replaced atomically and the
//!   link stays;
//! - anything else that exists (a character or block device, a FIFO, a
//!   socket) and `-` (standard output) is written through, never replaced;
//!   a short write (e.g. `/dev/full`) is an error;
//! - errors name the user's path, never the temporary one.
//!
//! [`check_output`] refuses, before any work is done, an output that is one
//! of the command's inputs (same device and inode, also through symbolic
//! links or hard links) or that cannot be written (a folder, a missing folder).

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// The marker in temporary file names: `.NAME.citypvs-tmp-PID-XXXXXXXX`.
const TMP_MARKER: &str = ".citypvs-tmp-";

/// Longest chain of symbolic links followed.
const MAX_LINKS: usize = 40;

/// True when `path` is `-`, which means standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Where writing `path` really goes: the path itself, or the final target
/// of the chain of symbolic links starting at it (which may not exist yet).
fn resolve_links(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = fs::read_link(&p).map_err(|e| io_error(path, "cannot follow", e))?;
                p = match p.parent() {
                    Some(dir) if target.is_relative() => dir.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(Error::io(format!(
        "{}: cannot write: more than {MAX_LINKS} symbolic links to follow",
        path.display()
    )))
}

fn io_error(path: &Path, what: &str, e: io::Error) -> Error {
    // The io::Error's own text never holds a path (tempfile's would).
    let text = e
        .raw_os_error()
        .map(|code| io::Error::from_raw_os_error(code).to_string())
        .unwrap_or_else(|| e.to_string());
    Error::io(format!("{}: {what}: {text}", path.display()))
}

/// The folder holding `path` (`.` for a bare file name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// (device, inode) of what `path` names after following links, if it exists.
#[cfg(unix)]
fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(path: &Path) -> Option<PathBuf> {
    fs::canonicalize(path).ok()
}

/// Refuse an output that would overwrite one of `inputs` (the same file by
/// device and inode, also through symbolic or hard links), that is a
/// folder, or whose folder does not exist. Call it before the work.
pub fn check_output(output: &Path, inputs: &[&Path]) -> Result<()> {
    if is_stdout(output) {
        return Ok(());
    }
    if let Some(out_id) = identity(output) {
        for input in inputs {
            if identity(input) == Some(out_id) {
                return Err(Error::io(format!(
                    "{}: the output is the input {}: refusing to overwrite it (choose another -o)",
                    output.display(),
                    input.display()
                )));
            }
        }
    }
    let target = resolve_links(output)?;
    match fs::metadata(&target) {
        Ok(m) if m.is_dir() => Err(Error::io(format!(
            "{}: cannot write: it is a folder (give a file name)",
            output.display()
        ))),
        Ok(_) => Ok(()),
        Err(_) => {
            let dir = folder_of(&target);
            if dir.is_dir() {
                Ok(())
            } else {
                Err(Error::io(format!(
                    "{}: cannot write: the folder {} does not exist",
                    output.display(),
                    dir.display()
                )))
            }
        }
    }
}

/// Write `contents` to `path` following the rules in the module doc.
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<()> {
    write_atomically_with(path, &mut |w| w.write_all(contents))
}

/// [`write_atomically`] of the bytes that `write` writes, handed out as
/// they are made (they are never all held at once).
pub fn write_atomically_with(
    path: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> io::Result<()>,
) -> Result<()> {
    if is_stdout(path) {
        let mut out = io::stdout().lock();
        return write(&mut out)
            .and_then(|()| out.flush())
            .map_err(|e| io_error(path, "cannot write to standard output", e));
    }
    let target = resolve_links(path)?;
    match fs::metadata(&target) {
        Ok(m) if m.is_dir() => Err(Error::io(format!(
            "{}: cannot write: it is a folder",
            path.display()
        ))),
        Ok(m) if !m.is_file() => write_through(path, &target, write),
        _ => replace(path, &target, write),
    }
}

/// Write into an existing non-regular file (device, FIFO) without replacing it.
fn write_through(
    path: &Path,
    target: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> io::Result<()>,
) -> Result<()> {
    let mut f = OpenOptions::new()
        .write(true)
        .open(target)
        .map_err(|e| io_error(path, "cannot open for writing", e))?;
    write(&mut f)
        .and_then(|()| f.flush())
        .map_err(|e| io_error(path, "cannot write", e))
}

/// Temporary file names of `target`'s output start with this.
fn tmp_prefix(target: &Path) -> String {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!(".{name}{TMP_MARKER}")
}

/// True when the process that made a temporary file with this name (the
/// part after the prefix is `PID-XXXXXXXX`) is gone.
fn is_stale(rest: &str, modified: Option<std::time::SystemTime>) -> bool {
    let pid: Option<u32> = rest.split('-').next().and_then(|p| p.parse().ok());
    if pid == Some(std::process::id()) {
        return false;
    }
    if cfg!(target_os = "linux")
        && let Some(pid) = pid
    {
        return !Path::new(&format!("/proc/{pid}")).exists();
    }
    // Elsewhere: stale once it has not been touched for an hour.
    modified
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age.as_secs() > 3600)
}

/// Remove temporary files of this same output left by killed runs.
fn remove_stale(dir: &Path, prefix: &str) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if let Some(rest) = name.strip_prefix(prefix) {
            let modified = entry.metadata().and_then(|m| m.modified()).ok();
            let is_file = entry.file_type().is_ok_and(|t| t.is_file());
            if is_file && is_stale(rest, modified) {
                let _ = fs::remove_file(entry.path());
            }
        }
    }
}

/// Create a new temporary file next to `target`.
fn create_tmp(path: &Path, dir: &Path, prefix: &str) -> Result<(PathBuf, File)> {
    use std::sync::atomic::{AtomicU32, Ordering};
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let mut last = None;
    for _ in 0..16 {
        // A tag no other file of this process has, mixed with the clock so
        // a process with a recycled id does not meet its predecessor's.
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let tag = COUNTER
            .fetch_add(1, Ordering::Relaxed)
            .wrapping_mul(0x9e37_79b9)
            ^ nanos;
        let tmp = dir.join(format!("{prefix}{}-{tag:08x}", std::process::id()));
        let mut options = OpenOptions::new();
        options.write(true).create_new(true);
        // Like a plain create: readable by others as the umask allows.
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            options.mode(0o666);
        }
        match options.open(&tmp) {
            Ok(f) => return Ok((tmp, f)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(io_error(path, "cannot write", e)),
        }
    }
    Err(io_error(
        path,
        "cannot write",
        last.unwrap_or_else(|| io::Error::other("no free temporary name")),
    ))
}

/// Replace (or create) the regular file `target` atomically.
fn replace(
    path: &Path,
    target: &Path,
    write: &mut dyn FnMut(&mut dyn Write) -> io::Result<()>,
) -> Result<()> {
    let dir = folder_of(target);
    let prefix = tmp_prefix(target);
    remove_stale(&dir, &prefix);
    let (tmp, mut file) = create_tmp(path, &dir, &prefix)?;
    let written = write(&mut file)
        .and_then(|()| file.sync_all())
        .and_then(|()| {
            drop(file);
            fs::rename(&tmp, target)
        });
    written.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        io_error(path, "cannot write", e)
    })
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

    #[test]
    fn temporary_names_carry_the_output_name_and_a_pid() {
        let prefix = tmp_prefix(Path::new("dir/city.pvs"));
        assert_eq!(prefix, ".city.pvs.citypvs-tmp-");
        assert!(!is_stale(&format!("{}-0000abcd", std::process::id()), None));
        assert!(is_stale("4294967295-0000abcd", None) || !cfg!(target_os = "linux"));
    }
}
