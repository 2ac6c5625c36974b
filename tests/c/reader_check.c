/* Exercises include/citypvs.h on a .pvs file and prints every answer as
 * text, for tests/capi_reader.rs to compare with `citypvs inspect --json`.
 * Usage: reader_check FILE.pvs
 * Output lines:
 *   cells N / objects M
 *   id I ID                  (every object)
 *   cell C K V1 ... VK       (every cell: its visible object indices)
 *   at C L I                 (cell found at C's centroid, local then input frame)
 *   ok                       (the error paths behaved)
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "citypvs.h"

static void die(const char *what, int code) {
    fprintf(stderr, "%s failed (%d): %s\n", what, code, citypvs_last_error());
    exit(1);
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: reader_check FILE.pvs LON_LAT_POINTS.txt\n");
        return 2;
    }
    citypvs_reader *r = NULL;
    int rc = citypvs_open_path(argv[1], &r);
    if (rc != CITYPVS_OK) die("open_path", rc);
    uint32_t cells = citypvs_cell_count(r), objects = citypvs_object_count(r);
    printf("cells %u\nobjects %u\n", cells, objects);
    for (uint32_t i = 0; i < objects; i++) {
        size_t len = 0;
        rc = citypvs_object_id(r, i, NULL, 0, &len);
        if (rc != CITYPVS_ERR_BUFFER_TOO_SMALL) die("object_id size query", rc);
        char *buf = malloc(len + 1);
        rc = citypvs_object_id(r, i, buf, len + 1, &len);
        if (rc != CITYPVS_OK) die("object_id", rc);
        printf("id %u %s\n", i, buf);
        free(buf);
    }
    for (uint32_t c = 0; c < cells; c++) {
        size_t count = 0;
        rc = citypvs_visible(r, c, NULL, 0, &count);
        if (rc != CITYPVS_ERR_BUFFER_TOO_SMALL && !(rc == CITYPVS_OK && count == 0))
            die("visible size query", rc);
        uint32_t *set = malloc((count + 1) * sizeof *set);
        rc = citypvs_visible(r, c, set, count, &count);
        if (rc != CITYPVS_OK) die("visible", rc);
        printf("cell %u %zu", c, count);
        for (size_t k = 0; k < count; k++) printf(" %u", set[k]);
        printf("\n");
        free(set);
    }
    /* Points in the input frame, one "x y" per line, from the test. */
    FILE *pts = fopen(argv[2], "r");
    if (!pts) {
        perror(argv[2]);
        return 1;
    }
    for (uint32_t c = 0; c < cells; c++) {
        double xy[6], ix, iy;
        rc = citypvs_cell_triangle(r, c, xy);
        if (rc != CITYPVS_OK) die("cell_triangle", rc);
        if (fscanf(pts, "%lf %lf", &ix, &iy) != 2) {
            fprintf(stderr, "short points file\n");
            return 1;
        }
        double x = (xy[0] + xy[2] + xy[4]) / 3, y = (xy[1] + xy[3] + xy[5]) / 3;
        uint32_t local = 0, input = 0;
        rc = citypvs_cell_at_local(r, x, y, &local);
        if (rc != CITYPVS_OK) die("cell_at_local", rc);
        rc = citypvs_cell_at_input(r, ix, iy, &input);
        if (rc != CITYPVS_OK) die("cell_at_input", rc);
        printf("at %u %u %u\n", c, local, input);
    }
    fclose(pts);
    /* Error paths: far away, a small buffer, no such cell, bad bytes. */
    uint32_t cell;
    if (citypvs_cell_at_local(r, 1e9, 1e9, &cell) != CITYPVS_NOT_FOUND) die("far point", -1);
    size_t count = 0;
    uint32_t one;
    for (uint32_t c = 0; c < cells; c++) {
        rc = citypvs_visible(r, c, &one, 1, &count);
        if (count > 1 && rc != CITYPVS_ERR_BUFFER_TOO_SMALL) die("small buffer", rc);
    }
    if (citypvs_visible(r, cells, &one, 1, &count) != CITYPVS_ERR_ARGUMENT) die("no such cell", -1);
    if (strlen(citypvs_last_error()) == 0) die("error message", -1);
    const uint8_t junk[16] = "CITYPVS\0junkjunk";
    citypvs_reader *bad = NULL;
    if (citypvs_open_memory(junk, sizeof junk, &bad) != CITYPVS_ERR_FORMAT || bad) die("junk bytes", -1);
    if (citypvs_open_path("/nonexistent/x.pvs", &bad) != CITYPVS_ERR_IO) die("missing file", -1);
    /* The same file from memory gives the same counts. */
    FILE *f = fopen(argv[1], "rb");
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *bytes = malloc(len);
    if (fread(bytes, 1, len, f) != (size_t)len) return 1;
    fclose(f);
    citypvs_reader *m = NULL;
    rc = citypvs_open_memory(bytes, len, &m);
    free(bytes);
    if (rc != CITYPVS_OK) die("open_memory", rc);
    if (citypvs_cell_count(m) != cells || citypvs_object_count(m) != objects) die("memory counts", -1);
    citypvs_close(m);
    citypvs_close(r);
    citypvs_close(NULL);
    printf("ok\n");
    return 0;
}
