/*
 * core/hash.c: FNV-1a (Fowler, Noll and Vo; 64-bit offset basis and prime as published) over
 * memory and files (core/hash.h).
 */
#include "core/hash.h"

#include <stdio.h>

#define SPC_FNV_PRIME 0x100000001b3ull
#define SPC_HASH_FILE_CHUNK 16384 /* bytes per read: the calls cost nothing next to the hashing */

uint64_t spc_fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; ++i) {
        h ^= p[i];
        h *= SPC_FNV_PRIME;
    }
    return h;
}

bool spc_fnv1a_file(uint64_t *h, const char *path)
{
    FILE *fp = path ? fopen(path, "rb") : NULL;
    if (!fp)
        return false;
    unsigned char buf[SPC_HASH_FILE_CHUNK];
    uint64_t total = 0;
    for (size_t n; (n = fread(buf, 1, sizeof buf, fp)) > 0;) {
        *h = spc_fnv1a(*h, buf, n);
        total += n;
    }
    bool ok = ferror(fp) == 0;
    fclose(fp);
    /* the length ends the file's bytes, so that two files hashed in a row cannot trade bytes */
    *h = spc_fnv1a(*h, &total, sizeof total);
    return ok;
}
