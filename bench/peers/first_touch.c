/* First touch of fresh anonymous memory: MiB threads huge(0|1), three rounds in one process.
 * Shows what an extraction's output costs to fault in on this machine, apart from isoforge:
 *   gcc -O2 -pthread bench/peers/first_touch.c -o /tmp/first_touch && /tmp/first_touch 400 1 1
 * (docs/BENCHMARKS.md §6.6). */
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <time.h>

static size_t bytes;
static char *buf;
static int threads;

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + t.tv_nsec * 1e-9;
}

static void *touch(void *arg) {
    long i = (long)arg;
    size_t lo = bytes / threads * i, hi = bytes / threads * (i + 1);
    for (size_t p = lo; p < hi; p += 4096) buf[p] = 1;
    return 0;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: first_touch MIB THREADS HUGE(0|1)\n");
        return 2;
    }
    bytes = (size_t)atol(argv[1]) << 20;
    threads = atoi(argv[2]);
    int huge = atoi(argv[3]);
    if (threads < 1 || threads > 8 || bytes == 0) return 2;
    for (int round = 0; round < 3; round++) {
        buf = mmap(0, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (buf == MAP_FAILED) return 1;
        if (huge) madvise(buf, bytes, MADV_HUGEPAGE);
        double t0 = now();
        pthread_t th[8];
        for (long i = 0; i < threads; i++) pthread_create(&th[i], 0, touch, (void *)i);
        for (int i = 0; i < threads; i++) pthread_join(th[i], 0);
        double s = now() - t0;
        printf("%zu MiB, %d threads, huge %d: %.3f s (%.2f GB/s)\n", bytes >> 20, threads, huge, s, bytes / 1e9 / s);
        munmap(buf, bytes);
    }
    return 0;
}
