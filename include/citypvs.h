/* citypvs.h - C interface to the citypvs .pvs reader (format version 3).
 *
 * Build the library with `cargo build --release --features capi` (or, for
 * a reader without the baker, `--no-default-features --features capi`);
 * link target/release/libcitypvs.a (plus -lpthread -ldl -lm on Linux) or
 * libcitypvs.so.
 *
 * Every function returning int returns a status code below. After a
 * failure, citypvs_last_error() gives a NUL-terminated message for the
 * calling thread, valid until the next failing call on that thread.
 *
 * Buffers follow the size query pattern: pass a NULL buffer (or one too
 * small) and the function stores the size needed and returns
 * CITYPVS_ERR_BUFFER_TOO_SMALL without writing the buffer; call again with
 * a large enough buffer.
 *
 * Object indices are positions in the file's object table (the input's
 * order); visible sets are strictly ascending object indices.
 * A reader may be used from several threads at once (no call mutates it);
 * citypvs_close must not race with other calls on the same reader.
 */
#ifndef CITYPVS_H
#define CITYPVS_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define CITYPVS_OK 0
#define CITYPVS_NOT_FOUND 1            /* no cell holds the point */
#define CITYPVS_ERR_BUFFER_TOO_SMALL 2 /* size stored; call again */
#define CITYPVS_ERR_ARGUMENT 3         /* null pointer, no such cell/object */
#define CITYPVS_ERR_IO 4               /* the file cannot be read */
#define CITYPVS_ERR_FORMAT 5           /* not a valid .pvs file */
#define CITYPVS_ERR_INTERNAL 6         /* a bug in citypvs */

typedef struct CitypvsReader citypvs_reader;

/* Message of the last failed call on this thread ("" if none). */
const char *citypvs_last_error(void);

/* Open a file by path (UTF-8). On success *out is a reader for citypvs_close. */
int citypvs_open_path(const char *path, citypvs_reader **out);
/* Open a file held in memory; the bytes are copied. */
int citypvs_open_memory(const uint8_t *bytes, size_t len, citypvs_reader **out);
/* Close a reader; NULL is ignored. */
void citypvs_close(citypvs_reader *reader);

uint32_t citypvs_cell_count(const citypvs_reader *reader);
uint32_t citypvs_object_count(const citypvs_reader *reader);

/* The id of an object, NUL-terminated, into buf of cap bytes; *len gets its
 * length without the NUL (so cap must be at least *len + 1). */
int citypvs_object_id(const citypvs_reader *reader, uint32_t object, char *buf, size_t cap,
                      size_t *len);

/* The cell holding a point in local metres (x east, y north), or
 * CITYPVS_NOT_FOUND. A point on an edge shared by two cells goes to the
 * lower-numbered one. */
int citypvs_cell_at_local(const citypvs_reader *reader, double x, double y, uint32_t *cell);
/* The same for a point in the input's frame: longitude, latitude (degrees)
 * for a lon/lat file, the input's metres for a metric one. */
int citypvs_cell_at_input(const citypvs_reader *reader, double x, double y, uint32_t *cell);

/* The triangle of a cell in local metres: xy[0..6] = x0 y0 x1 y1 x2 y2. */
int citypvs_cell_triangle(const citypvs_reader *reader, uint32_t cell, double xy[6]);

/* The visible set of a cell into buf of cap entries; *count gets its size. */
int citypvs_visible(const citypvs_reader *reader, uint32_t cell, uint32_t *buf, size_t cap,
                    size_t *count);

#ifdef __cplusplus
}
#endif

#endif /* CITYPVS_H */
