// What a warm loop pays to write a fresh output buffer (docs/BENCHMARKS.md §6.17).
//
//   cc -O2 -o /tmp/first_touch bench/scripts/first_touch.c
//   /tmp/first_touch MIB ROUNDS [huge]
//
// Each round mallocs MIB MiB, writes every byte, and frees it, as `isoforge extract --repeat` does
// with a mesh's arrays; prints the median and minimum round. `huge` asks for huge pages on the
// 2 MiB-aligned part, as isoforge's `huge_capacity` does. glibc serves blocks of 32 MiB and more
// with their own mmap and unmaps them on free, so every round faults them in again (the kernel
// zeroes each page); smaller blocks come back from the heap already mapped.
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static int by_value(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s MIB ROUNDS [huge]\n", argv[0]);
        return 2;
    }
    size_t bytes = (size_t)atol(argv[1]) << 20;
    int rounds = atoi(argv[2]);
    int huge = argc > 3;
    const uintptr_t page = 2u << 20;
    double *t = malloc(rounds * sizeof *t);
    if (bytes == 0 || rounds <= 0 || !t) {
        fprintf(stderr, "first_touch: MIB and ROUNDS must be positive\n");
        return 2;
    }
    for (int i = 0; i < rounds; i++) {
        double start = now();
        char *p = malloc(bytes);
        if (!p) {
            fprintf(stderr, "first_touch: cannot allocate %zu bytes\n", bytes);
            return 1;
        }
        if (huge) {
            uintptr_t a = ((uintptr_t)p + page - 1) & ~(page - 1), e = ((uintptr_t)p + bytes) & ~(page - 1);
            if (e > a) madvise((void *)a, e - a, MADV_HUGEPAGE);
        }
        memset(p, i, bytes);
        __asm__ volatile("" : : "r"(p) : "memory");
        free(p);
        t[i] = now() - start;
    }
    qsort(t, rounds, sizeof *t, by_value);
    printf("%zu MiB%s: median %.2f ms (%.1f GB/s), min %.2f ms\n", bytes >> 20, huge ? " (huge pages)" : "",
           t[rounds / 2] * 1e3, bytes / t[rounds / 2] / 1e9, t[0] * 1e3);
    return 0;
}
