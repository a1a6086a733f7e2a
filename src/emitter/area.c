/*
 * emitter/area.c: area light on any shape, one-sided (emits on the side of the shape's normal).
 *
 * Sampling, as seen from a reference point:
 * - spheres seen from outside: the cone of directions they subtend (solid angle);
 * - meshes of at most AREA_TEX_MAX_TRIS triangles with uvs whose radiance is a bitmap texture:
 *   in proportion to the texels (below);
 * - every other shape: uniform area.
 * Area densities are converted to solid angle at the reference point (pdf_area dist^2 / |cos_l|).
 *
 * Texel-proportional sampling. A texture's uv map need not be one-to-one (repeats, to_uv, several
 * triangles over the same texels), so rather than sampling a texel and looking for the surface
 * that shows it, we sample the SURFACE in proportion to an upper bound of its radiance: each
 * triangle t is cut into k_t^2 congruent sub-triangles (its barycentric domain subdivided k_t
 * times per edge, k_t ~ the longest edge's length in texels, so a sub-triangle spans about one
 * texel), each sub-triangle c gets the weight
 *     w_c = area_c * max { mean(texel) : texels the texture reads anywhere in c },
 * (the texels of c's uv bounding box, widened by one texel for bilinear filtering, with the
 * texture's wrap mode), a sub-triangle is drawn from the discrete distribution of the w_c, and a
 * point uniformly in it. The density with respect to area is
 *     pdf_area(x) = pmf(c(x)) / area_c(x),
 * piecewise constant, and positive wherever the radiance is (w_c bounds it from above), so the
 * estimator stays unbiased; it is proportional to the radiance up to the texel-scale blur of the
 * max. spc_area_pdf_direct / spc_area_pdf_emission receive a point, not a triangle, so they find
 * the triangle holding it by a linear search: that is why the method is reserved to meshes of at
 * most AREA_TEX_MAX_TRIS triangles (quads, rectangles, boxes: the textured lights of real scenes);
 * larger meshes and analytic shapes keep uniform (or solid-angle) sampling.
 *
 * XML: <emitter type="area"> radiance (rgb or texture, default 1), nested in a <shape>.
 */
#include "emitter/variants.h"

#include <stdlib.h>
#include <string.h>

#include "scene/shape.h"

#define AREA_TEX_MAX_TRIS 256        /* texel sampling only for meshes this small (linear pdf search) */
#define AREA_TEX_MAX_CELLS (1 << 22) /* sub-triangles over all triangles: 4M (~100 MB at most) */
#define AREA_TEX_MAX_K 2048          /* subdivisions per triangle edge */
#define AREA_LOCATE_TOL 1e-3         /* accepted distance (relative to the triangle) of a located point */

static bool textured_mesh(const spc_emitter *e)
{
    const spc_shape *s = e->shape;
    const spc_texture *t = e->radiance;
    return s->type == SPC_SHAPE_MESH && s->mesh.uv && s->mesh.ntris > 0 && s->mesh.ntris <= AREA_TEX_MAX_TRIS &&
           t->type == SPC_TEX_BITMAP && t->data && t->width > 0 && t->height > 0;
}

/* Texel-space position (continuous, x along the width) of a surface uv. */
static spc_vec2 texel_pos(const spc_texture *t, double u, double v)
{
    const double(*m)[3] = t->to_uv;
    double su = m[0][0] * u + m[0][1] * v + m[0][2], sv = m[1][0] * u + m[1][1] * v + m[1][2];
    return spc_v2(su * t->width, sv * t->height);
}

static double tri_area(const spc_mesh *m, size_t i)
{
    spc_vec3 p0 = spc_mesh_p(m, m->idx[3 * i]), p1 = spc_mesh_p(m, m->idx[3 * i + 1]), p2 = spc_mesh_p(m, m->idx[3 * i + 2]);
    return 0.5 * spc_length(spc_cross(spc_sub(p1, p0), spc_sub(p2, p0)));
}

/* Barycentrics (b1, b2) of the corners of sub-triangle l of a triangle cut k times per edge.
 * Cells 0 .. k(k+1)/2 - 1 point "up": grid corners (i,j), (i+1,j), (i,j+1) for i + j <= k - 1,
 * ordered by i then j; the k(k-1)/2 after them point "down": (i+1,j), (i+1,j+1), (i,j+1) for
 * i + j <= k - 2. Grid coordinates are (b1, b2) times k. */
static void cell_corners(int k, size_t l, spc_vec2 c[3])
{
    size_t nup = (size_t)k * (size_t)(k + 1) / 2;
    bool up = l < nup;
    size_t r = up ? l : l - nup;
    int n = up ? k : k - 1; /* row i holds n - i cells */
    /* the row: the largest i with i n - i (i - 1) / 2 <= r */
    double a = n + 0.5;
    int i = (int)floor(a - sqrt(spc_max(0.0, a * a - 2.0 * (double)r)));
    if (i < 0)
        i = 0;
    while (i > 0 && (size_t)i * (size_t)n - (size_t)i * (size_t)(i - 1) / 2 > r)
        --i;
    while ((size_t)(i + 1) * (size_t)n - (size_t)(i + 1) * (size_t)i / 2 <= r)
        ++i;
    int j = (int)(r - ((size_t)i * (size_t)n - (size_t)i * (size_t)(i - 1) / 2));
    double s = 1.0 / k;
    if (up) {
        c[0] = spc_v2(i * s, j * s);
        c[1] = spc_v2((i + 1) * s, j * s);
        c[2] = spc_v2(i * s, (j + 1) * s);
    } else {
        c[0] = spc_v2((i + 1) * s, j * s);
        c[1] = spc_v2((i + 1) * s, (j + 1) * s);
        c[2] = spc_v2(i * s, (j + 1) * s);
    }
}

/* Index of the sub-triangle holding barycentrics (b1, b2) (the inverse of cell_corners). */
static size_t cell_index(int k, double b1, double b2)
{
    double x = spc_clamp(b1, 0.0, 1.0) * k, y = spc_clamp(b2, 0.0, 1.0) * k;
    int i = (int)floor(x), j = (int)floor(y);
    if (i > k - 1)
        i = k - 1;
    if (j > k - 1)
        j = k - 1;
    if (i + j > k - 1) /* past the hypotenuse by rounding */
        j = k - 1 - i;
    bool up = (x - i) + (y - j) < 1.0 || i + j == k - 1;
    int n = up ? k : k - 1;
    size_t base = up ? 0 : (size_t)k * (size_t)(k + 1) / 2;
    if (!up && i + j > k - 2)
        j = k - 2 - i;
    return base + (size_t)i * (size_t)n - (size_t)i * (size_t)(i - 1) / 2 + (size_t)j;
}

/* Largest texel mean the texture reads for texel-space points in the box [x0,x1] x [y0,y1]. */
static double max_texel(const spc_texture *t, double x0, double x1, double y0, double y1)
{
    int64_t ix0, ix1, iy0, iy1;
    if (t->nearest) {
        ix0 = (int64_t)floor(x0);
        ix1 = (int64_t)floor(x1);
        iy0 = (int64_t)floor(y0);
        iy1 = (int64_t)floor(y1);
    } else {
        ix0 = (int64_t)floor(x0 - 0.5);
        ix1 = (int64_t)floor(x1 - 0.5) + 1;
        iy0 = (int64_t)floor(y0 - 0.5);
        iy1 = (int64_t)floor(y1 - 0.5) + 1;
    }
    /* a box wider than the image reads every texel (wrapping repeats them) */
    if (ix1 - ix0 >= t->width) {
        ix0 = 0;
        ix1 = t->width - 1;
    }
    if (iy1 - iy0 >= t->height) {
        iy0 = 0;
        iy1 = t->height - 1;
    }
    double m = 0.0;
    for (int64_t y = iy0; y <= iy1; ++y)
        for (int64_t x = ix0; x <= ix1; ++x)
            m = spc_max(m, spc_rgb_avg(spc_texture_texel(t, x, y)));
    return m;
}

static bool build_cells(spc_emitter *e)
{
    const spc_mesh *m = &e->shape->mesh;
    const spc_texture *t = e->radiance;
    size_t nt = m->ntris;
    e->cell_offset = malloc((nt + 1) * sizeof(size_t));
    e->cell_k = malloc(nt * sizeof(int));
    if (!e->cell_offset || !e->cell_k)
        return false;
    /* subdivisions: about one texel per sub-triangle edge, within the global budget */
    double total = 0.0;
    for (size_t i = 0; i < nt; ++i) {
        spc_vec2 q[3];
        for (int c = 0; c < 3; ++c) {
            uint32_t v = m->idx[3 * i + (size_t)c];
            q[c] = texel_pos(t, m->uv[2 * v], m->uv[2 * v + 1]);
        }
        double len = 0.0;
        for (int c = 0; c < 3; ++c) {
            spc_vec2 a = q[c], b = q[(c + 1) % 3];
            len = spc_max(len, sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y)));
        }
        double k = spc_clamp(ceil(len), 1.0, (double)AREA_TEX_MAX_K);
        e->cell_k[i] = (int)k;
        total += k * k;
    }
    double shrink = total > AREA_TEX_MAX_CELLS ? sqrt(AREA_TEX_MAX_CELLS / total) : 1.0;
    size_t ncells = 0;
    for (size_t i = 0; i < nt; ++i) {
        if (shrink < 1.0)
            e->cell_k[i] = (int)spc_max(1.0, floor(e->cell_k[i] * shrink));
        e->cell_offset[i] = ncells;
        ncells += (size_t)e->cell_k[i] * (size_t)e->cell_k[i];
    }
    e->cell_offset[nt] = ncells;
    double *w = malloc(ncells * sizeof(double));
    if (!w)
        return false;
    for (size_t i = 0; i < nt; ++i) {
        int k = e->cell_k[i];
        double a = tri_area(m, i) / ((double)k * k);
        spc_vec2 q[3];
        for (int c = 0; c < 3; ++c) {
            uint32_t v = m->idx[3 * i + (size_t)c];
            q[c] = texel_pos(t, m->uv[2 * v], m->uv[2 * v + 1]);
        }
        for (size_t l = 0; l < (size_t)k * (size_t)k; ++l) {
            spc_vec2 b[3];
            cell_corners(k, l, b);
            double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
            for (int c = 0; c < 3; ++c) {
                double b0 = 1.0 - b[c].x - b[c].y;
                double x = b0 * q[0].x + b[c].x * q[1].x + b[c].y * q[2].x;
                double y = b0 * q[0].y + b[c].x * q[1].y + b[c].y * q[2].y;
                x0 = spc_min(x0, x);
                x1 = spc_max(x1, x);
                y0 = spc_min(y0, y);
                y1 = spc_max(y1, y);
            }
            double wt = isfinite(x0) && isfinite(x1) && isfinite(y0) && isfinite(y1) ? max_texel(t, x0, x1, y0, y1) : 0.0;
            w[e->cell_offset[i] + l] = a * wt;
        }
    }
    bool ok = spc_distrib1d_init(&e->cell_distrib, w, ncells);
    free(w);
    return ok;
}

void spc_area_release(spc_emitter *e)
{
    if (e->type != SPC_EMITTER_AREA)
        return;
    if (e->has_cell_distrib)
        spc_distrib1d_release(&e->cell_distrib);
    free(e->cell_offset);
    free(e->cell_k);
    e->cell_offset = NULL;
    e->cell_k = NULL;
    e->has_cell_distrib = false;
}

bool spc_area_prepare(spc_emitter *e)
{
    if (!e->shape || !e->radiance)
        return false;
    spc_area_release(e);
    e->power = SPC_PI * e->shape->area * spc_rgb_avg(spc_texture_mean(e->radiance));
    if (e->power > 0.0 && textured_mesh(e)) {
        e->has_cell_distrib = build_cells(e);
        if (!e->has_cell_distrib)
            spc_area_release(e); /* out of memory or black: uniform sampling stays correct */
    }
    return e->power > 0.0;
}

spc_rgb spc_area_eval(const spc_emitter *e, spc_vec2 uv, spc_vec3 n, spc_vec3 w)
{
    if (spc_dot(n, w) <= 0.0)
        return spc_rgb1(0.0);
    return spc_texture_eval(e->radiance, uv);
}

/* A point by the texel-proportional distribution; false if none. */
static bool sample_cells(const spc_emitter *e, spc_vec2 u, spc_shape_sample *out)
{
    const spc_shape *s = e->shape;
    double ux;
    size_t c = spc_distrib1d_sample(&e->cell_distrib, u.x, &ux);
    double pmf = e->cell_distrib.pmf[c];
    if (!(pmf > 0.0))
        return false;
    /* the triangle: the last offset <= c */
    size_t lo = 0, hi = s->mesh.ntris;
    while (hi - lo > 1) {
        size_t mid = (lo + hi) / 2;
        if (e->cell_offset[mid] <= c)
            lo = mid;
        else
            hi = mid;
    }
    int k = e->cell_k[lo];
    spc_vec2 b[3];
    cell_corners(k, c - e->cell_offset[lo], b);
    spc_vec2 w = spc_warp_uniform_triangle(spc_v2(ux, u.y));
    double w0 = 1.0 - w.x - w.y;
    double b1 = w0 * b[0].x + w.x * b[1].x + w.y * b[2].x, b2 = w0 * b[0].y + w.x * b[1].y + w.y * b[2].y;
    spc_hit h;
    memset(&h, 0, sizeof h);
    spc_shape_fill_hit(s, (int)lo, b1, b2, NULL, 0.0, &h);
    out->p = h.p;
    out->n = h.ng;
    out->uv = h.uv;
    out->err = h.err;
    out->prim = (int)lo;
    out->pdf = pmf * (double)k * (double)k / tri_area(&s->mesh, lo);
    return isfinite(out->pdf) && out->pdf > 0.0;
}

/* Area density of sample_cells at the point p of the mesh: the triangle holding p is found by a
 * linear search (the smallest barycentric violation, among triangles whose plane p is on). */
static double pdf_cells(const spc_emitter *e, spc_vec3 p)
{
    const spc_mesh *m = &e->shape->mesh;
    size_t best = m->ntris;
    double best_bad = INFINITY, bb1 = 0.0, bb2 = 0.0;
    for (size_t i = 0; i < m->ntris; ++i) {
        spc_vec3 p0 = spc_mesh_p(m, m->idx[3 * i]), p1 = spc_mesh_p(m, m->idx[3 * i + 1]), p2 = spc_mesh_p(m, m->idx[3 * i + 2]);
        spc_vec3 e1 = spc_sub(p1, p0), e2 = spc_sub(p2, p0), d = spc_sub(p, p0);
        spc_vec3 n = spc_cross(e1, e2);
        double n2 = spc_length2(n);
        if (!(n2 > 0.0))
            continue;
        /* distance to the plane, relative to the triangle's size */
        double size = sqrt(spc_max(spc_length2(e1), spc_length2(e2)));
        double off = fabs(spc_dot(d, n)) / sqrt(n2) / size;
        double b1 = spc_dot(spc_cross(d, e2), n) / n2, b2 = spc_dot(spc_cross(e1, d), n) / n2;
        double bad = spc_max(spc_max(-b1, -b2), spc_max(b1 + b2 - 1.0, 0.0)) + off;
        if (bad < best_bad) {
            best_bad = bad;
            best = i;
            bb1 = b1;
            bb2 = b2;
        }
        if (bad <= 0.0)
            break;
    }
    if (best == m->ntris || !(best_bad < AREA_LOCATE_TOL))
        return 0.0;
    int k = e->cell_k[best];
    size_t c = e->cell_offset[best] + cell_index(k, bb1, bb2);
    return e->cell_distrib.pmf[c] * (double)k * (double)k / tri_area(m, best);
}

/* Area density of the position sampling (any shape, uniform or texel-proportional). */
static double pdf_area(const spc_emitter *e, spc_vec3 p)
{
    return e->has_cell_distrib ? pdf_cells(e, p) : 1.0 / e->shape->area;
}

static bool sample_area(const spc_emitter *e, spc_vec2 u, spc_shape_sample *ss)
{
    if (e->has_cell_distrib)
        return sample_cells(e, u, ss);
    spc_shape_sample_area(e->shape, u, ss);
    return true;
}

bool spc_area_sample_direct(const spc_emitter *e, spc_vec3 ref, spc_vec2 u, spc_emitter_direct *out)
{
    const spc_shape *s = e->shape;
    spc_shape_sample ss;
    double pdf;
    if (!e->has_cell_distrib && spc_shape_sample_solid_angle(s, ref, u, !spc_texture_is_constant(e->radiance), &ss)) {
        pdf = ss.pdf;
    } else {
        if (!sample_area(e, u, &ss))
            return false;
        spc_vec3 d = spc_sub(ss.p, ref);
        double dist2 = spc_length2(d);
        double cosl = fabs(spc_dot(ss.n, d)) / sqrt(dist2);
        if (!(cosl > 0.0) || !(dist2 > 0.0))
            return false;
        pdf = ss.pdf * dist2 / cosl;
        ss.err /= spc_max(cosl, SPC_AREA_GRAZING_COS); /* along the ray (emitter.h) */
    }
    spc_vec3 d = spc_sub(ss.p, ref);
    double dist = spc_length(d);
    if (!(dist > 0.0) || !(pdf > 0.0) || !isfinite(pdf))
        return false;
    out->p = ss.p;
    out->n = ss.n;
    out->wi = spc_scale(d, 1.0 / dist);
    out->dist = dist;
    out->L = spc_area_eval(e, ss.uv, ss.n, spc_neg(out->wi));
    out->pdf = pdf;
    out->err = ss.err;
    return !spc_rgb_is_black(out->L);
}

double spc_area_pdf_direct(const spc_emitter *e, spc_vec3 ref, spc_vec3 p, spc_vec3 n)
{
    const spc_shape *s = e->shape;
    if (!e->has_cell_distrib && spc_shape_has_solid_angle_sampling(s, ref))
        return spc_shape_pdf_solid_angle(s, ref, p);
    spc_vec3 d = spc_sub(p, ref);
    double dist2 = spc_length2(d);
    double cosl = fabs(spc_dot(n, d)) / sqrt(dist2);
    if (!(cosl > 0.0))
        return 0.0;
    return pdf_area(e, p) * dist2 / cosl;
}

bool spc_area_sample_emission(const spc_emitter *e, spc_vec2 u_pos, spc_vec2 u_dir, spc_emitter_emission *out)
{
    spc_shape_sample ss;
    if (!sample_area(e, u_pos, &ss) || !(ss.pdf > 0.0))
        return false;
    spc_vec3 l = spc_warp_cosine_hemisphere(u_dir);
    if (!(l.z > 0.0))
        return false;
    spc_frame fr = spc_frame_from_n(ss.n);
    out->p = ss.p;
    out->n = ss.n;
    out->d = spc_frame_to_world(&fr, l);
    out->pdf_pos = ss.pdf;
    out->pdf_dir = l.z * SPC_INV_PI;
    out->err = ss.err;
    spc_rgb Le = spc_texture_eval(e->radiance, ss.uv);
    out->weight = spc_rgb_scale(Le, SPC_PI / ss.pdf); /* Le cos / (pdf_pos cos/pi) */
    return !spc_rgb_is_black(out->weight);
}

void spc_area_pdf_emission(const spc_emitter *e, spc_vec3 p, spc_vec3 n, spc_vec3 d, double *pdf_pos,
                           double *pdf_dir)
{
    *pdf_pos = pdf_area(e, p);
    double c = spc_dot(n, d);
    *pdf_dir = c > 0.0 ? c * SPC_INV_PI : 0.0;
}
