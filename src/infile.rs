//! File input: every file citypvs reads whole (a city, a region, a `.pvs`,
//! a shard or a checkpoint) goes through [`read_whole`], which never reads
//! without bound.
//!
//! - A regular file larger than [`MAX_FILE_BYTES`] is refused from its size,
//!   before anything is read or allocated.
//! - Anything else (a pipe, `/dev/stdin`, a process substitution, a device)
//!   has no size to check: it is read until it ends, and refused once it
//!   passes [`MAX_FILE_BYTES`]; and as soon as its first [`SNIFF_BYTES`]
//!   are in, they must look like the start of the file expected, so that
//!   `/dev/zero` or `/dev/urandom` is refused at once instead of after
//!   gigabytes.

use std::io::Read;
use std::path::Path;

use crate::{Error, Result};

/// Largest file citypvs reads: 4 GiB. A GeoJSON file of 100,000
/// buildings is about 25 MB, and a city is at most 100 km wide.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

/// How much of a stream is read before its start is checked.
pub const SNIFF_BYTES: usize = 64 << 10;

/// Read all of `path`. `starts_right` is shown the first [`SNIFF_BYTES`]
/// of a stream longer than that; `what` names the file expected, for the
/// message when they do not fit ("a city file", "a .pvs file"). Errors are
/// of kind `Io` and start with the path.
pub fn read_whole(
    path: &Path,
    starts_right: impl Fn(&[u8]) -> bool,
    what: &str,
) -> Result<Vec<u8>> {
    let name = path.display();
    let cannot = |e: std::io::Error| Error::io(format!("{name}: cannot read: {e}"));
    let too_large = || {
        Error::io(format!(
            "{name}: larger than {} GiB, the most citypvs reads",
            MAX_FILE_BYTES >> 30
        ))
    };
    let mut file = std::fs::File::open(path).map_err(cannot)?;
    let meta = file.metadata().map_err(cannot)?;
    let mut bytes = Vec::new();
    if meta.is_file() {
        if meta.len() > MAX_FILE_BYTES {
            return Err(too_large());
        }
        bytes.reserve_exact(meta.len() as usize);
    } else {
        (&mut file)
            .take(SNIFF_BYTES as u64)
            .read_to_end(&mut bytes)
            .map_err(cannot)?;
        if bytes.len() == SNIFF_BYTES && !starts_right(&bytes) {
            return Err(Error::io(format!(
                "{name}: does not start like {what} (read from a stream, which is checked after its first {} KiB)",
                SNIFF_BYTES >> 10
            )));
        }
    }
    // Also a regular file that grows while it is read stops at the limit.
    file.take(MAX_FILE_BYTES + 1 - bytes.len() as u64)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(too_large());
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regular_file_is_read_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        let data: Vec<u8> = (0..200_000u32).map(|i| (i % 251) as u8).collect();
        std::fs::write(&path, &data).unwrap();
        // Regular files are not sniffed: a start that fails the check is read.
        assert_eq!(read_whole(&path, |_| false, "x").unwrap(), data);
        let missing = dir.path().join("missing");
        let err = read_whole(&missing, |_| true, "x").unwrap_err();
        assert!(err.to_string().contains("missing: cannot read"), "{err}");
    }

    #[cfg(unix)]
    #[test]
    fn an_endless_stream_of_the_wrong_bytes_is_refused_at_once() {
        let zero = Path::new("/dev/zero");
        if !zero.exists() {
            return;
        }
        let err = read_whole(zero, |b| b[0] == b'{', "a city file").unwrap_err();
        assert!(
            err.to_string()
                .starts_with("/dev/zero: does not start like a city file"),
            "{err}"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_stream_is_read_to_its_end() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return;
        }
        let data: Vec<u8> = (0..300_000u32).map(|i| b'a' + (i % 26) as u8).collect();
        let writer = {
            let (fifo, data) = (fifo.clone(), data.clone());
            std::thread::spawn(move || std::fs::write(fifo, data).unwrap())
        };
        let read = read_whole(&fifo, |b| b[0] == b'a', "letters").unwrap();
        writer.join().unwrap();
        assert_eq!(read, data);
    }
}
