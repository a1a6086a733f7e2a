/*
 * fuzz/fuzz_cli.c: libFuzzer harness for the numbers of the command line: the `specula` command's
 * own parsers (tools/specula.c is compiled in, its main renamed) and the specular-NEE option
 * string the library parses (--specular-nee NAME:OPTS). The input is split at NUL bytes into
 * arguments; each is parsed as every kind of number the command takes. A parser that accepts a
 * value must return it within the range it was asked for; one that crashes, overflows (UBSan) or
 * reads past the string (ASan) is the finding. Built with -DSPC_FUZZ=ON (clang); run by
 * fuzz/run.sh.
 */
#include "fuzz_targets.h"

#include "manifold/specular_nee.h"

/* the command's other functions (render, diff, info) are not called here */
#pragma GCC diagnostic ignored "-Wunused-function"
#define main specula_main
#include "../tools/specula.c"
#undef main

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_one(const char *a)
{
    int i = 0, j = 0;
    if (parse_int(a, 1, INT_MAX, &i) && i < 1)
        abort();
    if (parse_int(a, -1, 4096, &i) && (i < -1 || i > 4096))
        abort();
    uint64_t u = 0;
    (void)parse_u64(a, &u);
    double d = 0.0;
    if (parse_double(a, &d) && !isfinite(d))
        abort();
    if (parse_pair(a, 'x', 1, MAX_FILM_SIDE, &i, &j) && (i < 1 || j < 1 || i > MAX_FILM_SIDE || j > MAX_FILM_SIDE))
        abort();
    if (parse_pair(a, ',', 0, 1000000, &i, &j) && (i < 0 || j < 0))
        abort();
    spc_snee_params p;
    if (spc_snee_parse(a, 2, &p) && (p.max_chain < 1 || p.max_chain > SPC_CHAIN_MAX_VERTICES))
        abort();
    /* the option forms: --name=value and --name value */
    const char *argv[3] = {"--res", a, NULL};
    const char *v = NULL;
    int k = 0;
    if (opt_value(2, (char **)argv, &k, "--res", NULL, &v) && (k != 2 || v != a))
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > 4096)
        return 0;
    char *buf = malloc(size + 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    for (size_t start = 0; start <= size;) {
        check_one(buf + start);
        start += strlen(buf + start) + 1;
    }
    free(buf);
    return 0;
}
