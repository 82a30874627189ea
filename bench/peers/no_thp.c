/* Runs a command with transparent huge pages disabled for it and its children (PR_SET_THP_DISABLE),
 * so isoforge's MADV_HUGEPAGE advice has no effect: the A/B of docs/BENCHMARKS.md §6.7.
 *   gcc -O2 bench/peers/no_thp.c -o /tmp/no_thp && /tmp/no_thp target/release/isoforge extract ...
 * For the peer harness, point --isoforge at a two-line script that execs /tmp/no_thp with the binary. */
#include <stdio.h>
#include <sys/prctl.h>
#include <unistd.h>

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: no_thp PROGRAM [ARGS...]\n");
        return 2;
    }
    if (prctl(PR_SET_THP_DISABLE, 1, 0, 0, 0) != 0) {
        perror("no_thp: prctl(PR_SET_THP_DISABLE)");
        return 1;
    }
    execvp(argv[1], argv + 1);
    perror("no_thp: exec");
    return 127;
}
