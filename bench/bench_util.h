/*
 * bench/bench_util.h: what the benchmarks that read a scene file share: the clocks, the
 * `-D name=value` arguments and loading the scene with its error printed. Header-only.
 *
 * Clocks: the machine is shared, so a benchmark of one thread's work times it by that thread's CPU
 * time (bench_thread_seconds), of several threads' by the process's (bench_process_seconds); wall
 * time (bench_wall_seconds) only where the benchmark compares against its own wall-time figures.
 */
#ifndef SPC_BENCH_UTIL_H
#define SPC_BENCH_UTIL_H

#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "specula/specula.h"

/* The most -D definitions a benchmark takes. */
#define BENCH_MAX_DEFINES 32

static inline double bench_clock(clockid_t id)
{
    struct timespec ts;
    clock_gettime(id, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline double bench_thread_seconds(void) { return bench_clock(CLOCK_THREAD_CPUTIME_ID); }
static inline double bench_process_seconds(void) { return bench_clock(CLOCK_PROCESS_CPUTIME_ID); }
static inline double bench_wall_seconds(void) { return bench_clock(CLOCK_MONOTONIC); }

/* If argv[*i] is "-D" followed by name=value, stores the pair in defs[*nd] (pointing into argv,
 * whose '=' becomes the name's end), moves *i to the value and returns true; a pair without '=' is
 * skipped. false (nothing moved) for any other argument, or when defs already holds
 * BENCH_MAX_DEFINES pairs. */
static inline bool bench_define_arg(int argc, char **argv, int *i, spc_define defs[BENCH_MAX_DEFINES], int *nd)
{
    if (strcmp(argv[*i], "-D") != 0 || *i + 1 >= argc || *nd >= BENCH_MAX_DEFINES)
        return false;
    char *eq = strchr(argv[++*i], '=');
    if (eq) {
        *eq = '\0';
        defs[*nd].name = argv[*i];
        defs[*nd].value = eq + 1;
        ++*nd;
    }
    return true;
}

/* The scene at path with the definitions defs[0..nd); NULL after printing the loader's error
 * (file:line:col: message) to stderr. The caller destroys the scene. */
static inline spc_scene *bench_load(const char *path, const spc_define *defs, int nd)
{
    spc_scene *sc = NULL;
    spc_error err;
    if (spc_scene_load(path, defs, nd, &sc, &err) != SPC_OK) {
        char buf[1200];
        spc_error_format(&err, buf, sizeof buf);
        fprintf(stderr, "%s\n", buf);
        return NULL;
    }
    return sc;
}

#endif
