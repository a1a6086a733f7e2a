/* Whole-file reads and byte comparison for tests that check renders are identical (EXRs of two
 * runs, a packet render against the one-ray render). */
#ifndef SPC_TESTS_FILE_UTIL_H
#define SPC_TESTS_FILE_UTIL_H

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The file's bytes (malloc'ed, the caller frees) and its size; NULL if it cannot be read. */
static inline unsigned char *slurp(const char *path, long *size)
{
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return NULL;
    fseek(fp, 0, SEEK_END);
    *size = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *b = malloc(*size > 0 ? (size_t)*size : 1);
    if (b && fread(b, 1, (size_t)*size, fp) != (size_t)*size) {
        free(b);
        b = NULL;
    }
    fclose(fp);
    return b;
}

/* Both files readable and byte for byte the same. */
static inline bool same_file(const char *a, const char *b)
{
    long na = -1, nb = -2;
    unsigned char *pa = slurp(a, &na), *pb = slurp(b, &nb);
    bool same = pa && pb && na == nb && memcmp(pa, pb, (size_t)na) == 0;
    free(pa);
    free(pb);
    return same;
}

#endif
