/* zlib-only reference for the end-to-end benchmark (end_to_end.py): the time a gzip NRRD's body
 * takes to decompress on one core with the system zlib, and nothing else.
 *
 * Reads the NRRD header up to its blank line, checks `encoding: gzip` and that the header is
 * attached (no `data file`), then inflates the body in 1 MiB input reads into one reused 1 MiB
 * output buffer written to /dev/null. Prints `{"bytes": N, "crc_ok": true}` (N = decompressed
 * bytes, checked against the gzip trailer by zlib itself) on stdout.
 *
 *     gcc -O2 -o zlib_inflate zlib_inflate.c -lz
 *     ./zlib_inflate CT.nrrd
 *
 * Exit status: 0 success, 2 bad input (message on stderr naming the file). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define CHUNK (1 << 20)
#define MAX_HEADER (1 << 20)

static int fail(const char *path, const char *what) {
    fprintf(stderr, "%s: %s\n", path, what);
    return 2;
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s FILE.nrrd\n", argv[0]);
        return 2;
    }
    const char *path = argv[1];
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        return 2;
    }
    /* Header: lines up to the first empty one. */
    char line[8192];
    long header_bytes = 0;
    int gzip = 0, detached = 0, first = 1;
    for (;;) {
        if (!fgets(line, sizeof line, f)) return fail(path, "no blank line ends the NRRD header");
        size_t n = strlen(line);
        header_bytes += (long)n;
        if (header_bytes > MAX_HEADER) return fail(path, "header longer than 1 MiB");
        if (first && strncmp(line, "NRRD000", 7) != 0) return fail(path, "line 1 is not an NRRD magic");
        first = 0;
        if (strcmp(line, "\n") == 0 || strcmp(line, "\r\n") == 0) break;
        if (strncmp(line, "encoding: gzip", 14) == 0 || strncmp(line, "encoding: gz\n", 13) == 0) gzip = 1;
        if (strncmp(line, "data file:", 10) == 0 || strncmp(line, "datafile:", 9) == 0) detached = 1;
    }
    if (!gzip) return fail(path, "encoding is not gzip");
    if (detached) return fail(path, "detached data file: give the data file to gzip instead");

    unsigned char *in = malloc(CHUNK), *out = malloc(CHUNK);
    FILE *sink = fopen("/dev/null", "wb");
    if (!in || !out || !sink) return fail(path, "out of memory or no /dev/null");
    z_stream z;
    memset(&z, 0, sizeof z);
    if (inflateInit2(&z, 16 + MAX_WBITS) != Z_OK) return fail(path, "inflateInit2 failed");
    unsigned long long total = 0;
    int ret = Z_OK;
    while (ret != Z_STREAM_END) {
        z.avail_in = (uInt)fread(in, 1, CHUNK, f);
        if (ferror(f)) return fail(path, "read error");
        if (z.avail_in == 0) return fail(path, "gzip data: the stream is cut (no end of stream)");
        z.next_in = in;
        /* As zlib's own example: call inflate until it leaves output space unused. */
        do {
            z.next_out = out;
            z.avail_out = CHUNK;
            ret = inflate(&z, Z_NO_FLUSH);
            if (ret != Z_OK && ret != Z_STREAM_END && ret != Z_BUF_ERROR) {
                fprintf(stderr, "%s: gzip data: corrupt after %llu bytes: %s\n", path, total,
                        z.msg ? z.msg : "inflate error");
                return 2;
            }
            size_t got = CHUNK - z.avail_out;
            total += got;
            if (got && fwrite(out, 1, got, sink) != got) return fail(path, "write to /dev/null failed");
        } while (z.avail_out == 0 && ret != Z_STREAM_END);
    }
    inflateEnd(&z);
    printf("{\"bytes\": %llu, \"crc_ok\": true, \"zlib\": \"%s\"}\n", total, zlibVersion());
    return 0;
}
