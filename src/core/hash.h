/*
 * core/hash.h: FNV-1a (64 bit) over memory and over whole files, for content hashes that must be
 * the same in every run and on every machine (checkpoints compare them: render/checkpoint.h). Not
 * a cryptographic hash: it tells an edited file from the original, not a forged one.
 */
#ifndef SPC_CORE_HASH_H
#define SPC_CORE_HASH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* FNV-1a, 64 bit: h is the running hash (start with SPC_FNV_OFFSET). */
#define SPC_FNV_OFFSET 0xcbf29ce484222325ull
uint64_t spc_fnv1a(uint64_t h, const void *data, size_t n);

/* Folds every byte of the file at path, then its length, into *h. false if it cannot be opened or
 * read through (*h then holds whatever was folded in before the failure). */
bool spc_fnv1a_file(uint64_t *h, const char *path);

#endif
