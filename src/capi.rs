//! The C ABI reader (feature `capi`; header `include/citypvs.h`): open a
//! `.pvs` file from a path or from memory, query its cells and objects, find
//! the cell at a point, and copy a cell's visible set into the caller's
//! buffer. Every function returns a status code; the message of the last
//! error on the calling thread is available from `citypvs_last_error`.
//! No function panics across the boundary: a panic would be a bug, and is
//! caught and reported as `CITYPVS_ERR_INTERNAL`.

use std::cell::RefCell;
use std::ffi::{CStr, CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use glam::DVec2;

use crate::pvs::PvsReader;

/// Success.
pub const CITYPVS_OK: i32 = 0;
/// No cell holds the point.
pub const CITYPVS_NOT_FOUND: i32 = 1;
/// The caller's buffer is too small; the needed size was stored.
pub const CITYPVS_ERR_BUFFER_TOO_SMALL: i32 = 2;
/// A null pointer or an argument out of range.
pub const CITYPVS_ERR_ARGUMENT: i32 = 3;
/// The file could not be read.
pub const CITYPVS_ERR_IO: i32 = 4;
/// The bytes are not a valid `.pvs` file (or a cell's set is malformed).
pub const CITYPVS_ERR_FORMAT: i32 = 5;
/// A bug in citypvs.
pub const CITYPVS_ERR_INTERNAL: i32 = 6;

/// An open file (opaque to C).
pub struct CitypvsReader {
    reader: PvsReader,
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

fn set_error(message: &str) {
    let clean: String = message.chars().filter(|&c| c != '\0').collect();
    LAST_ERROR.with(|e| *e.borrow_mut() = CString::new(clean).unwrap_or_default());
}

fn fail(code: i32, message: &str) -> i32 {
    set_error(message);
    code
}

fn guard(f: impl FnOnce() -> i32) -> i32 {
    catch_unwind(AssertUnwindSafe(f))
        .unwrap_or_else(|_| fail(CITYPVS_ERR_INTERNAL, "internal error"))
}

/// The message of the last failed call on this thread ("" if none). Valid
/// until the next failing call on the same thread.
#[unsafe(no_mangle)]
pub extern "C" fn citypvs_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

fn store(out: *mut *mut CitypvsReader, result: crate::Result<PvsReader>, io: bool) -> i32 {
    match result {
        Ok(reader) => {
            let boxed = Box::new(CitypvsReader { reader });
            // SAFETY: `out` was checked non-null by the caller of `store`.
            unsafe { *out = Box::into_raw(boxed) };
            CITYPVS_OK
        }
        Err(e) => fail(
            if io {
                CITYPVS_ERR_IO
            } else {
                CITYPVS_ERR_FORMAT
            },
            e.message(),
        ),
    }
}

/// Open the file at `path` (UTF-8, NUL-terminated). On success `*out` is a
/// reader to pass to `citypvs_close`.
///
/// # Safety
/// `path` must be a NUL-terminated string and `out` a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_open_path(
    path: *const c_char,
    out: *mut *mut CitypvsReader,
) -> i32 {
    guard(|| {
        if path.is_null() || out.is_null() {
            return fail(CITYPVS_ERR_ARGUMENT, "null path or output pointer");
        }
        // SAFETY: non-null and NUL-terminated by the contract.
        let path = unsafe { CStr::from_ptr(path) };
        let Ok(path) = path.to_str() else {
            return fail(CITYPVS_ERR_ARGUMENT, "path is not UTF-8");
        };
        let starts_right = |b: &[u8]| b.starts_with(&crate::pvs::MAGIC);
        let bytes = match crate::infile::read_whole(Path::new(path), starts_right, "a .pvs file") {
            Ok(b) => b,
            Err(e) => return fail(CITYPVS_ERR_IO, &e.to_string()),
        };
        store(
            out,
            PvsReader::from_bytes(bytes).map_err(|e| e.context(path)),
            false,
        )
    })
}

/// Open a file held in memory (`len` bytes at `bytes`; copied, so the
/// caller's buffer may be freed afterwards).
///
/// # Safety
/// `bytes` must point to `len` readable bytes and `out` be a valid pointer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_open_memory(
    bytes: *const u8,
    len: usize,
    out: *mut *mut CitypvsReader,
) -> i32 {
    guard(|| {
        if (bytes.is_null() && len > 0) || out.is_null() {
            return fail(CITYPVS_ERR_ARGUMENT, "null bytes or output pointer");
        }
        let data = if len == 0 {
            Vec::new()
        } else {
            // SAFETY: `len` readable bytes by the contract.
            unsafe { std::slice::from_raw_parts(bytes, len) }.to_vec()
        };
        store(out, PvsReader::from_bytes(data), false)
    })
}

/// Close a reader (null is ignored).
///
/// # Safety
/// `reader` must come from an open function and not be used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_close(reader: *mut CitypvsReader) {
    if !reader.is_null() {
        // SAFETY: created by Box::into_raw in `store`.
        drop(unsafe { Box::from_raw(reader) });
    }
}

/// # Safety
/// `reader` must be null or a live reader.
unsafe fn get<'a>(reader: *const CitypvsReader) -> Option<&'a PvsReader> {
    // SAFETY: by the contract.
    unsafe { reader.as_ref() }.map(|r| &r.reader)
}

/// Number of cells (0 for a null reader).
///
/// # Safety
/// `reader` must be null or a live reader.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_cell_count(reader: *const CitypvsReader) -> u32 {
    unsafe { get(reader) }.map_or(0, |r| r.cell_count() as u32)
}

/// Number of objects (0 for a null reader).
///
/// # Safety
/// `reader` must be null or a live reader.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_object_count(reader: *const CitypvsReader) -> u32 {
    unsafe { get(reader) }.map_or(0, |r| r.object_ids().len() as u32)
}

/// Copy the id of `object` (UTF-8, NUL-terminated) into `buf` of `cap`
/// bytes. `*len` gets the id's length without the NUL. If `cap` is too
/// small (or `buf` null), nothing is copied and the result is
/// `CITYPVS_ERR_BUFFER_TOO_SMALL`: call again with `cap >= *len + 1`.
///
/// # Safety
/// `reader` live, `buf` null or `cap` writable bytes, `len` valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_object_id(
    reader: *const CitypvsReader,
    object: u32,
    buf: *mut c_char,
    cap: usize,
    len: *mut usize,
) -> i32 {
    guard(|| {
        let Some(r) = (unsafe { get(reader) }) else {
            return fail(CITYPVS_ERR_ARGUMENT, "null reader");
        };
        if len.is_null() {
            return fail(CITYPVS_ERR_ARGUMENT, "null length pointer");
        }
        let Some(id) = r.object_ids().get(object as usize) else {
            return fail(
                CITYPVS_ERR_ARGUMENT,
                &format!(
                    "object {object} does not exist (the file has {})",
                    r.object_ids().len()
                ),
            );
        };
        // SAFETY: checked non-null.
        unsafe { *len = id.len() };
        if buf.is_null() || cap < id.len() + 1 {
            return fail(CITYPVS_ERR_BUFFER_TOO_SMALL, "buffer too small for the id");
        }
        // SAFETY: `cap >= id.len() + 1` writable bytes.
        unsafe {
            std::ptr::copy_nonoverlapping(id.as_ptr(), buf as *mut u8, id.len());
            *buf.add(id.len()) = 0;
        }
        CITYPVS_OK
    })
}

fn cell_at(reader: *const CitypvsReader, p: Option<DVec2>, cell: *mut u32) -> i32 {
    guard(|| {
        let Some(r) = (unsafe { get(reader) }) else {
            return fail(CITYPVS_ERR_ARGUMENT, "null reader");
        };
        if cell.is_null() {
            return fail(CITYPVS_ERR_ARGUMENT, "null cell pointer");
        }
        match p.and_then(|p| r.cell_at(p)) {
            Some(c) => {
                // SAFETY: checked non-null.
                unsafe { *cell = c as u32 };
                CITYPVS_OK
            }
            None => fail(CITYPVS_NOT_FOUND, "no cell holds the point"),
        }
    })
}

/// The cell holding the point (`x`, `y`) in local metres (a point on a
/// shared edge goes to the lower-numbered cell). `CITYPVS_NOT_FOUND` if none.
///
/// # Safety
/// `reader` live, `cell` valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_cell_at_local(
    reader: *const CitypvsReader,
    x: f64,
    y: f64,
    cell: *mut u32,
) -> i32 {
    cell_at(reader, Some(DVec2::new(x, y)), cell)
}

/// The cell holding the point (`x`, `y`) in the input's frame (longitude
/// and latitude in degrees for a lon/lat file, the input's metres for a
/// metric one).
///
/// # Safety
/// `reader` live, `cell` valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_cell_at_input(
    reader: *const CitypvsReader,
    x: f64,
    y: f64,
    cell: *mut u32,
) -> i32 {
    let p = unsafe { get(reader) }.map(|r| r.info().frame.to_local(x, y));
    cell_at(reader, p.or(Some(DVec2::NAN)), cell)
}

/// Copy the visible set of `cell` (ascending object indices) into `buf` of
/// `cap` entries; `*count` gets the set's size. If `cap < *count` (or `buf`
/// is null) nothing is copied and the result is
/// `CITYPVS_ERR_BUFFER_TOO_SMALL`: call again with a buffer of `*count`.
///
/// # Safety
/// `reader` live, `buf` null or `cap` writable entries, `count` valid.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_visible(
    reader: *const CitypvsReader,
    cell: u32,
    buf: *mut u32,
    cap: usize,
    count: *mut usize,
) -> i32 {
    guard(|| {
        let Some(r) = (unsafe { get(reader) }) else {
            return fail(CITYPVS_ERR_ARGUMENT, "null reader");
        };
        if count.is_null() {
            return fail(CITYPVS_ERR_ARGUMENT, "null count pointer");
        }
        if cell as usize >= r.cell_count() {
            return fail(
                CITYPVS_ERR_ARGUMENT,
                &format!(
                    "cell {cell} does not exist (the file has {} cells)",
                    r.cell_count()
                ),
            );
        }
        let set = match r.visible(cell as usize) {
            Ok(s) => s,
            Err(e) => return fail(CITYPVS_ERR_FORMAT, e.message()),
        };
        // SAFETY: checked non-null.
        unsafe { *count = set.len() };
        if buf.is_null() || cap < set.len() {
            return fail(
                CITYPVS_ERR_BUFFER_TOO_SMALL,
                "buffer too small for the visible set",
            );
        }
        // SAFETY: `cap >= set.len()` writable entries.
        unsafe { std::ptr::copy_nonoverlapping(set.as_ptr(), buf, set.len()) };
        CITYPVS_OK
    })
}

/// The triangle of `cell` in local metres: `xy` gets x0 y0 x1 y1 x2 y2.
///
/// # Safety
/// `reader` live, `xy` 6 writable doubles.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn citypvs_cell_triangle(
    reader: *const CitypvsReader,
    cell: u32,
    xy: *mut f64,
) -> i32 {
    guard(|| {
        let Some(r) = (unsafe { get(reader) }) else {
            return fail(CITYPVS_ERR_ARGUMENT, "null reader");
        };
        if xy.is_null() || cell as usize >= r.cell_count() {
            return fail(CITYPVS_ERR_ARGUMENT, "null output or no such cell");
        }
        let t = r.cell_triangle(cell as usize);
        for (k, p) in t.iter().enumerate() {
            // SAFETY: 6 writable doubles.
            unsafe {
                *xy.add(2 * k) = p.x;
                *xy.add(2 * k + 1) = p.y;
            }
        }
        CITYPVS_OK
    })
}
