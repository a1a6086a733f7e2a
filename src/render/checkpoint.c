/*
 * render/checkpoint.c: writing, reading and checking render checkpoints (layout and the reason
 * resumed renders are bit-identical: render/checkpoint.h).
 *
 * Reading validates everything before trusting anything: the magic, the format, every length
 * against the file's size, then the CRC-32 over the whole file, and only then the version that
 * wrote it (so a damaged version field reads as "corrupt", not as "another version"). Sums are
 * read straight into the film-sized arrays, so a checkpoint costs no more memory than its film.
 */
#include "render/checkpoint.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

#include "integrator/integrator.h"
#include "io/image_io.h"
#include "specula/specula.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "checkpoints store doubles in host order, which is assumed little-endian"
#endif

static const char ckpt_magic[8] = {'S', 'P', 'C', 'C', 'K', 'P', 'T', '\0'};

#define CKPT_IO_CHUNK ((size_t)1 << 20) /* bytes per write or read call when streaming the sums */
#define CKPT_MAX_SIDE 65536             /* the driver's film limits */
#define CKPT_MAX_PIXELS (1LL << 28)

uint64_t spc_ckpt_scene_hash(const char *path, const spc_define *defs, int ndefs, uint64_t files_hash)
{
    uint64_t h = SPC_FNV_OFFSET;
    if (!spc_fnv1a_file(&h, path))
        return 0;
    for (int i = 0; i < ndefs; ++i) {
        const char *name = defs[i].name ? defs[i].name : "", *value = defs[i].value ? defs[i].value : "";
        h = spc_fnv1a(h, name, strlen(name) + 1);
        h = spc_fnv1a(h, value, strlen(value) + 1);
    }
    h = spc_fnv1a(h, &files_hash, sizeof files_hash);
    return h ? h : 1;
}

void spc_ckpt_settings_text(const struct spc_render_ctx *ctx, const char *specular_nee, uint64_t seed, bool aovs,
                            char *buf, size_t size)
{
    const spc_film_spec *fs = ctx->film;
    snprintf(buf, size,
             "integrator=%s;max_depth=%d;rr_depth=%d;hide_emitters=%d;strategy=%d,%d,%d;mis_balance=%d;"
             "specular_nee=%s;specular_max_chain=%d;seed=%llu;film=%dx%d;crop=%d,%d,%d,%d;filter=%d,%.17g,%.17g,steps%d;"
             "aovs=%d",
             spc_integrator_kind_name(ctx->kind), ctx->max_depth, ctx->rr_depth, (int)ctx->hide_emitters,
             ctx->strategy_s, ctx->strategy_t, (int)ctx->strategy_weighted, (int)ctx->mis_balance,
             specular_nee ? specular_nee : "", ctx->specular_max_chain, (unsigned long long)seed, fs->width,
             fs->height, ctx->crop_x,
             ctx->crop_y, ctx->width, ctx->height, (int)fs->rfilter, fs->filter_radius, fs->filter_stddev,
             SPC_FILTER_RESOLUTION, (int)aovs);
}

/* ---- little-endian fields ---- */

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; ++i)
        p[i] = (unsigned char)(v >> (8 * i));
}

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; ++i)
        p[i] = (unsigned char)(v >> (8 * i));
}

static uint32_t get_u32(const unsigned char *p)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i)
        v |= (uint32_t)p[i] << (8 * i);
    return v;
}

static uint64_t get_u64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
        v |= (uint64_t)p[i] << (8 * i);
    return v;
}

static int32_t get_i32(const unsigned char *p) { return (int32_t)get_u32(p); }

/* ---- writing ---- */

typedef struct writer {
    int fd;
    uLong crc;
    bool ok;
} writer;

static void w_bytes(writer *w, const void *data, size_t n)
{
    const unsigned char *p = data;
    while (w->ok && n > 0) {
        size_t k = n < CKPT_IO_CHUNK ? n : CKPT_IO_CHUNK;
        w->crc = crc32(w->crc, p, (uInt)k);
        w->ok = spc_write_all(w->fd, p, k);
        p += k;
        n -= k;
    }
}

spc_status spc_ckpt_write(const char *path, const struct spc_film *f, const spc_ckpt_meta *meta, spc_error *err)
{
    const char *user = meta->user ? meta->user : "";
    const char *scene_path = meta->scene_path ? meta->scene_path : "";
    size_t ls = strlen(meta->settings), lp = strlen(scene_path), lu = strlen(user);
    if (ls > SPC_CKPT_MAX_TEXT || lp > SPC_CKPT_MAX_TEXT || lu > SPC_CKPT_MAX_TEXT)
        return spc_error_set(err, SPC_ERR_LIMIT, path, 0, 0, "checkpoint text fields are too long");

    unsigned char h[SPC_CKPT_HEADER_BYTES];
    memset(h, 0, sizeof h);
    memcpy(h, ckpt_magic, 8);
    put_u32(h + 8, SPC_CKPT_FORMAT);
    strncpy((char *)h + 12, SPECULA_VERSION, 16);
    put_u64(h + 28, meta->scene_hash);
    put_u64(h + 36, spc_fnv1a(SPC_FNV_OFFSET, meta->settings, ls));
    put_u32(h + 44, (uint32_t)f->spp);
    put_u32(h + 48, (uint32_t)meta->spp_target);
    put_u64(h + 52, f->invalid_samples);
    const int dims[6] = {f->full_width, f->full_height, f->crop_x, f->crop_y, f->width, f->height};
    for (int i = 0; i < 6; ++i)
        put_u32(h + 60 + 4 * i, (uint32_t)dims[i]);
    put_u32(h + 84, f->has_aovs ? 1u : 0u);
    put_u32(h + 88, (uint32_t)ls);
    put_u32(h + 92, (uint32_t)lp);
    put_u32(h + 96, (uint32_t)lu);

    char tmp[4200];
    if (strlen(path) + 32 > sizeof tmp)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "checkpoint path too long");
    int fd = spc_atomic_open(path, tmp, sizeof tmp, err);
    if (fd < 0)
        return SPC_ERR_IO;
    writer w = {fd, crc32(0L, Z_NULL, 0), true};
    size_t n = (size_t)f->width * (size_t)f->height;
    w_bytes(&w, h, sizeof h);
    w_bytes(&w, meta->settings, ls);
    w_bytes(&w, scene_path, lp);
    w_bytes(&w, user, lu);
    w_bytes(&w, f->sum, 3 * n * sizeof(double));
    w_bytes(&w, f->sumsq, 3 * n * sizeof(double));
    if (f->has_aovs)
        w_bytes(&w, f->aov_sum, SPC_FILM_AOVS * n * sizeof(double));
    unsigned char tail[4];
    put_u32(tail, (uint32_t)w.crc);
    if (w.ok)
        w.ok = spc_write_all(fd, tail, 4);
    if (!w.ok) {
        int e = errno;
        spc_atomic_abort(fd, tmp);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot write the checkpoint: %s", strerror(e));
    }
    return spc_atomic_commit(fd, tmp, path, err);
}

/* ---- reading ---- */

typedef struct reader {
    FILE *fp;
    uLong crc;
} reader;

static bool r_bytes(reader *r, void *data, size_t n)
{
    unsigned char *p = data;
    while (n > 0) {
        size_t k = n < CKPT_IO_CHUNK ? n : CKPT_IO_CHUNK;
        if (fread(p, 1, k, r->fp) != k)
            return false;
        r->crc = crc32(r->crc, p, (uInt)k);
        p += k;
        n -= k;
    }
    return true;
}

/* A text field of len bytes; NULL with *nomem set if out of memory, NULL alone if unreadable. */
static char *r_text(reader *r, uint32_t len, bool *nomem)
{
    char *s = malloc((size_t)len + 1);
    if (!s) {
        *nomem = true;
        return NULL;
    }
    if (!r_bytes(r, s, len)) {
        free(s);
        return NULL;
    }
    s[len] = '\0';
    if (strlen(s) != len) { /* an embedded NUL: not something we wrote */
        free(s);
        return NULL;
    }
    return s;
}

void spc_checkpoint_destroy(spc_checkpoint *c)
{
    if (!c)
        return;
    free(c->settings);
    free(c->scene_path);
    free(c->user);
    free(c->sum);
    free(c->sumsq);
    free(c->aov_sum);
    free(c);
}

static spc_status corrupt(spc_error *err, const char *path, const char *why)
{
    return spc_error_set(err, SPC_ERR_PARSE, path, 0, 0, "not a usable checkpoint (%s): torn, damaged or not a specula "
                                                          "checkpoint",
                         why);
}

spc_status spc_checkpoint_load(const char *path, spc_checkpoint **out, spc_error *err)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "spc_checkpoint_load: no path or output given");
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open the checkpoint: %s", strerror(errno));
    struct stat st;
    long long fsize = fstat(fileno(fp), &st) == 0 ? (long long)st.st_size : -1;
    reader r = {fp, crc32(0L, Z_NULL, 0)};
    unsigned char h[SPC_CKPT_HEADER_BYTES];
    spc_checkpoint *c = NULL;
    spc_status status = SPC_OK;
    if (fsize < SPC_CKPT_HEADER_BYTES + 4 || !r_bytes(&r, h, sizeof h) || memcmp(h, ckpt_magic, 8) != 0) {
        status = corrupt(err, path, "no checkpoint header");
        goto fail;
    }
    if (get_u32(h + 8) != SPC_CKPT_FORMAT) {
        status = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0,
                               "checkpoint format %u; this specula (%s) reads format %u only", get_u32(h + 8),
                               SPECULA_VERSION, SPC_CKPT_FORMAT);
        goto fail;
    }
    c = calloc(1, sizeof *c);
    if (!c) {
        status = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the checkpoint");
        goto fail;
    }
    snprintf(c->path, sizeof c->path, "%s", path);
    memcpy(c->version, h + 12, 16);
    c->version[16] = '\0';
    c->scene_hash = get_u64(h + 28);
    c->settings_hash = get_u64(h + 36);
    c->spp_done = get_i32(h + 44);
    c->spp_target = get_i32(h + 48);
    c->invalid_samples = get_u64(h + 52);
    int *dims[6] = {&c->full_width, &c->full_height, &c->crop_x, &c->crop_y, &c->width, &c->height};
    for (int i = 0; i < 6; ++i)
        *dims[i] = get_i32(h + 60 + 4 * i);
    uint32_t aovs = get_u32(h + 84), ls = get_u32(h + 88), lp = get_u32(h + 92), lu = get_u32(h + 96);
    c->has_aovs = aovs == 1;
    if (aovs > 1 || ls > SPC_CKPT_MAX_TEXT || lp > SPC_CKPT_MAX_TEXT || lu > SPC_CKPT_MAX_TEXT || c->spp_done < 0 ||
        c->spp_target < 0 || c->full_width <= 0 || c->full_height <= 0 || c->full_width > CKPT_MAX_SIDE ||
        c->full_height > CKPT_MAX_SIDE || c->width <= 0 || c->height <= 0 || c->crop_x < 0 || c->crop_y < 0 ||
        c->crop_x > c->full_width - c->width || c->crop_y > c->full_height - c->height ||
        (long long)c->width * c->height > CKPT_MAX_PIXELS) {
        status = corrupt(err, path, "impossible header values");
        goto fail;
    }
    size_t n = (size_t)c->width * (size_t)c->height;
    long long expect = SPC_CKPT_HEADER_BYTES + (long long)ls + lp + lu +
                       (long long)(c->has_aovs ? 6 + SPC_FILM_AOVS : 6) * (long long)n * (long long)sizeof(double) + 4;
    if (fsize != expect) {
        status = corrupt(err, path, fsize < expect ? "the file is truncated" : "the file is too long");
        goto fail;
    }
    bool nomem = false;
    c->settings = r_text(&r, ls, &nomem);
    c->scene_path = c->settings ? r_text(&r, lp, &nomem) : NULL;
    c->user = c->scene_path ? r_text(&r, lu, &nomem) : NULL;
    if (!c->user) {
        status = nomem ? spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading the checkpoint")
                       : corrupt(err, path, "unreadable text fields");
        goto fail;
    }
    c->sum = malloc(3 * n * sizeof(double));
    c->sumsq = malloc(3 * n * sizeof(double));
    if (c->has_aovs)
        c->aov_sum = malloc(SPC_FILM_AOVS * n * sizeof(double));
    if (!c->sum || !c->sumsq || (c->has_aovs && !c->aov_sum)) {
        status = spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory for a %dx%d checkpoint", c->width,
                               c->height);
        goto fail;
    }
    bool ok = r_bytes(&r, c->sum, 3 * n * sizeof(double)) && r_bytes(&r, c->sumsq, 3 * n * sizeof(double)) &&
              (!c->has_aovs || r_bytes(&r, c->aov_sum, SPC_FILM_AOVS * n * sizeof(double)));
    uLong crc = r.crc;
    unsigned char tail[4];
    if (!ok || fread(tail, 1, 4, fp) != 4) {
        status = corrupt(err, path, "the file is truncated");
        goto fail;
    }
    if (get_u32(tail) != (uint32_t)crc) {
        status = corrupt(err, path, "checksum mismatch");
        goto fail;
    }
    if (c->settings_hash != spc_fnv1a(SPC_FNV_OFFSET, c->settings, ls)) {
        status = corrupt(err, path, "settings hash mismatch");
        goto fail;
    }
    if (strcmp(c->version, SPECULA_VERSION) != 0) {
        status = spc_error_set(err, SPC_ERR_VALUE, path, 0, 0,
                               "this checkpoint was written by specula %s; specula %s cannot resume it (render "
                               "again, or resume with specula %s)",
                               c->version, SPECULA_VERSION, c->version);
        goto fail;
    }
    fclose(fp);
    *out = c;
    return SPC_OK;
fail:
    fclose(fp);
    spc_checkpoint_destroy(c);
    return status;
}

void spc_checkpoint_get_info(const spc_checkpoint *c, spc_checkpoint_info *out)
{
    memset(out, 0, sizeof *out);
    if (!c)
        return;
    out->spp_done = c->spp_done;
    out->spp_target = c->spp_target;
    out->width = c->width;
    out->height = c->height;
    out->scene_path = c->scene_path;
    out->settings = c->settings;
    out->user = c->user;
    out->version = c->version;
}

/* The first "key=value" of a that differs from b's, for the refusal message. */
static void first_difference(const char *a, const char *b, char *out, size_t size)
{
    const char *pa = a, *pb = b;
    for (;;) {
        size_t na = strcspn(pa, ";"), nb = strcspn(pb, ";");
        if (na != nb || memcmp(pa, pb, na) != 0) {
            snprintf(out, size, "%.*s now, %.*s in the checkpoint", (int)na, pa, (int)nb, pb);
            return;
        }
        if (!pa[na] || !pb[nb]) {
            snprintf(out, size, "settings text differs");
            return;
        }
        pa += na + 1;
        pb += nb + 1;
    }
}

spc_status spc_ckpt_restore(const struct spc_checkpoint *c, uint64_t scene_hash, const char *settings,
                            struct spc_film *f, spc_error *err)
{
    if (c->scene_hash != scene_hash)
        return spc_error_set(err, SPC_ERR_VALUE, c->path, 0, 0,
                             "this checkpoint belongs to another scene: it was written for '%s' (hash %016llx), but "
                             "the scene being rendered differs (hash %016llx): its file, a file it references (mesh, "
                             "texture, envmap, include) or its -D definitions changed",
                             c->scene_path, (unsigned long long)c->scene_hash, (unsigned long long)scene_hash);
    if (strcmp(c->settings, settings) != 0) {
        char diff[512];
        first_difference(settings, c->settings, diff, sizeof diff);
        return spc_error_set(err, SPC_ERR_VALUE, c->path, 0, 0,
                             "the render settings differ from the checkpoint's (%s); resume with the same settings",
                             diff);
    }
    if (c->width != f->width || c->height != f->height || c->full_width != f->full_width ||
        c->full_height != f->full_height || c->crop_x != f->crop_x || c->crop_y != f->crop_y ||
        c->has_aovs != f->has_aovs)
        return spc_error_set(err, SPC_ERR_VALUE, c->path, 0, 0, "the checkpoint's film (%dx%d) does not match (%dx%d)",
                             c->width, c->height, f->width, f->height);
    size_t n = (size_t)f->width * (size_t)f->height;
    memcpy(f->sum, c->sum, 3 * n * sizeof(double));
    memcpy(f->sumsq, c->sumsq, 3 * n * sizeof(double));
    if (f->has_aovs)
        memcpy(f->aov_sum, c->aov_sum, SPC_FILM_AOVS * n * sizeof(double));
    f->spp = c->spp_done;
    f->invalid_samples = c->invalid_samples;
    return SPC_OK;
}
