#!/usr/bin/env python3
"""Read a .pvs file through the C ABI reader with ctypes.

Build the shared library first:
    cargo rustc --release --lib --no-default-features --features capi --crate-type cdylib
then run:
    python3 docs/capi_example.py target/release/libcitypvs.so city.pvs [x y]
It prints the counts, and the visible ids of the cell at local point (x, y)
(default: the first cell's centroid). See include/citypvs.h.
"""
import ctypes
import sys

OK, NOT_FOUND, BUFFER_TOO_SMALL = 0, 1, 2


def main():
    lib = ctypes.CDLL(sys.argv[1])
    lib.citypvs_last_error.restype = ctypes.c_char_p
    lib.citypvs_cell_count.restype = ctypes.c_uint32
    lib.citypvs_object_count.restype = ctypes.c_uint32
    lib.citypvs_cell_at_local.argtypes = [
        ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.POINTER(ctypes.c_uint32)]
    lib.citypvs_cell_count.argtypes = [ctypes.c_void_p]
    lib.citypvs_object_count.argtypes = [ctypes.c_void_p]
    lib.citypvs_close.argtypes = [ctypes.c_void_p]

    reader = ctypes.c_void_p()
    if lib.citypvs_open_path(sys.argv[2].encode(), ctypes.byref(reader)) != OK:
        sys.exit(lib.citypvs_last_error().decode())
    cells = lib.citypvs_cell_count(reader)
    print(f"{cells} cells, {lib.citypvs_object_count(reader)} objects")

    if len(sys.argv) >= 5:
        x, y = float(sys.argv[3]), float(sys.argv[4])
    else:
        xy = (ctypes.c_double * 6)()
        lib.citypvs_cell_triangle(reader, ctypes.c_uint32(0), xy)
        x, y = (xy[0] + xy[2] + xy[4]) / 3, (xy[1] + xy[3] + xy[5]) / 3
    cell = ctypes.c_uint32()
    rc = lib.citypvs_cell_at_local(reader, x, y, ctypes.byref(cell))
    if rc == NOT_FOUND:
        print(f"no cell at ({x}, {y})")
        return
    # Size query, then the real call.
    count = ctypes.c_size_t()
    rc = lib.citypvs_visible(reader, cell, None, ctypes.c_size_t(0), ctypes.byref(count))
    buf = (ctypes.c_uint32 * max(count.value, 1))()
    if lib.citypvs_visible(reader, cell, buf, count, ctypes.byref(count)) != OK:
        sys.exit(lib.citypvs_last_error().decode())
    ids = []
    for i in buf[: count.value]:
        n = ctypes.c_size_t()
        lib.citypvs_object_id(reader, ctypes.c_uint32(i), None, ctypes.c_size_t(0), ctypes.byref(n))
        s = ctypes.create_string_buffer(n.value + 1)
        lib.citypvs_object_id(reader, ctypes.c_uint32(i), s, ctypes.c_size_t(n.value + 1), ctypes.byref(n))
        ids.append(s.value.decode())
    print(f"cell {cell.value} at ({x:.2f}, {y:.2f}) sees {count.value} objects: {' '.join(ids[:10])}"
          + (" ..." if len(ids) > 10 else ""))
    lib.citypvs_close(reader)


if __name__ == "__main__":
    main()
