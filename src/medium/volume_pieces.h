/*
 * medium/volume_pieces.h: private to src/medium/. Cuts the ray o + t d, t in [t0, t1], into the
 * pieces on which a volume's value is one polynomial of t (a cubic for trilinear grids, a constant
 * for nearest grids and constant volumes): the pieces end where the ray crosses a plane of texel
 * centres (trilinear) or texel edges (nearest) of any axis. Usage:
 *   spc_volume_pieces it; double a, b;
 *   spc_volume_pieces_begin(&it, v, o, d, t0, t1);
 *   while (spc_volume_pieces_next(&it, &a, &b)) ...
 */
#ifndef SPC_MEDIUM_VOLUME_PIECES_H
#define SPC_MEDIUM_VOLUME_PIECES_H

#include "medium/medium.h"

/* Pieces walked per ray before giving up (a ray through a 4096^3 grid corner to corner crosses
 * about 3 x 4096 planes); beyond it the rest of the ray is left out. */
#define SPC_VOLUME_MAX_PIECES 65536

typedef struct spc_volume_pieces {
    const spc_volume *v;
    double t, t1;
    double o[3], d[3], res[3], off;
    double n[3], dir[3], next[3];
    int steps;
} spc_volume_pieces;

void spc_volume_pieces_begin(spc_volume_pieces *it, const spc_volume *v, spc_vec3 o, spc_vec3 d, double t0, double t1);
/* The next piece [*a, *b] (b > a); false when the ray is done. */
bool spc_volume_pieces_next(spc_volume_pieces *it, double *a, double *b);

#endif
