/*
 * core/cpu_isa.c: the vector instruction set of the batch kernels (cpu_isa.h).
 */
#include "core/cpu_isa.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

static int best = SPC_ISA_BASE;
static bool gfni = false;
static pthread_once_t best_once = PTHREAD_ONCE_INIT;

static void best_init(void)
{
#if defined(__GNUC__) && defined(__x86_64__)
    const char *cap = getenv("SPECULA_VECTOR_ISA");
    bool allow_gfni = !cap || strcmp(cap, "avx512gfni") == 0;
    bool allow512 = allow_gfni || strcmp(cap, "avx512") == 0, allow2 = allow512 || strcmp(cap, "avx2") == 0;
    if (allow512 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl")) {
        best = SPC_ISA_AVX512;
        gfni = allow_gfni && __builtin_cpu_supports("gfni");
    }
    else if (allow2 && __builtin_cpu_supports("avx2"))
        best = SPC_ISA_AVX2;
#endif
}

int spc_vector_isa(void)
{
    pthread_once(&best_once, best_init);
    return best;
}

bool spc_vector_gfni(void)
{
    pthread_once(&best_once, best_init);
    return gfni;
}
