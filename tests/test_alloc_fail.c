/*
 * tests/test_alloc_fail.c: allocation-failure injection (SQLite's way). Every malloc,
 * calloc and realloc that specula's own code makes goes through wrappers here (linked with
 * -Wl,--wrap=...; shared libraries such as expat, libpng, OpenEXR and Embree keep their own
 * allocator), which can be told to fail from the n-th call on. For every n from 0 to the number of
 * allocations a successful run makes, loading a scene that uses every kind of file (OBJ, PLY,
 * .serialized, PNG, JPEG and EXR textures, an envmap), setting up and running a render, writing
 * and reading a checkpoint and reading images must each fail with an error (or succeed), never
 * crash, and leave no allocation behind: the wrappers count live blocks, so a leak fails the test
 * even without LeakSanitizer (which CI's sanitizer build adds).
 */
/* ctest-labels: unit */
/* ctest-timeout: 600 */
/* ctest-link-options: -Wl,--wrap=malloc -Wl,--wrap=calloc -Wl,--wrap=realloc -Wl,--wrap=free */
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "harness.h"
#include "io/image_io.h"
#include "specula/specula.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

static atomic_long calls;          /* allocation calls since alloc_arm */
static atomic_long live;           /* blocks allocated through the wrappers and not yet freed */
static atomic_long fail_from = -1; /* calls numbered >= this fail; -1: none */
static atomic_long failed;         /* calls that were made to fail */

static bool should_fail(void)
{
    long k = atomic_fetch_add(&calls, 1);
    long f = atomic_load(&fail_from);
    if (f >= 0 && k >= f) {
        atomic_fetch_add(&failed, 1);
        return true;
    }
    return false;
}

void *__wrap_malloc(size_t n)
{
    if (should_fail())
        return NULL;
    void *p = __real_malloc(n);
    if (p)
        atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_calloc(size_t n, size_t size)
{
    if (should_fail())
        return NULL;
    void *p = __real_calloc(n, size);
    if (p)
        atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_realloc(void *p, size_t n)
{
    if (should_fail())
        return NULL;
    void *q = __real_realloc(p, n);
    if (!p && q)
        atomic_fetch_add(&live, 1);
    return q;
}

void __wrap_free(void *p)
{
    if (p)
        atomic_fetch_sub(&live, 1);
    __real_free(p);
}

/* Starts counting; allocations from call number `from` on fail (-1: none). */
static void alloc_arm(long from)
{
    atomic_store(&calls, 0);
    atomic_store(&failed, 0);
    atomic_store(&fail_from, from);
}

static long alloc_disarm(void)
{
    atomic_store(&fail_from, -1);
    return atomic_load(&calls);
}

static char scene_path[2048];
static char tmpdir[64];

/* One operation under test: returns its status; must free everything it made on failure. */
typedef spc_status (*op_fn)(void *ctx);

/* Runs op once to count its allocations, then once failing from each n in [0, count): every run
 * must give SPC_OK or an error with a message, and leave as many live blocks as before. */
static void inject(const char *what, op_fn op, void *ctx, long max_runs)
{
    long live0 = atomic_load(&live);
    alloc_arm(-1);
    spc_status st = op(ctx);
    long count = alloc_disarm();
    CHECK_MSG(st == SPC_OK, "%s: fails without injection: %s", what, spc_status_name(st));
    CHECK_MSG(atomic_load(&live) == live0, "%s: %ld blocks leaked without injection", what, atomic_load(&live) - live0);
    long step = count > max_runs ? count / max_runs + 1 : 1;
    int nomem = 0, other = 0, ok = 0;
    for (long n = 0; n < count; n += step) {
        alloc_arm(n);
        st = op(ctx);
        alloc_disarm();
        long leaked = atomic_load(&live) - live0;
        if (leaked != 0) {
            CHECK_MSG(0, "%s: failing from allocation %ld of %ld leaks %ld blocks (status %s)", what, n, count,
                      leaked, spc_status_name(st));
            atomic_store(&live, live0); /* report each leak once */
        }
        if (st == SPC_OK) {
            ++ok;
        } else if (st == SPC_ERR_NOMEM) {
            ++nomem;
        } else {
            if (other < 3) /* an allocation failure reported as something else: say what, but allow it */
                printf("    failing from allocation %ld: %s\n", n, spc_status_name(st));
            ++other;
        }
    }
    printf("  %s: %ld allocations; failing each: %d out-of-memory errors, %d other errors, %d successes\n", what,
           count, nomem, other, ok);
    CHECK(count > 0 && nomem > 0);
    /* an allocation failure must read as one: spc_shape_prepare once reported it as "zero area" */
    CHECK_MSG(other == 0, "%s: %d allocation failures reported as something other than out of memory", what, other);
}

/* ---- operations ---- */

typedef struct load_ctx {
    const char *path;
    const spc_define *defs;
    int ndefs;
} load_ctx;

static spc_status op_load(void *p)
{
    load_ctx *c = p;
    spc_scene *sc = NULL;
    spc_error err;
    err.msg[0] = '\0';
    spc_status st = spc_scene_load(c->path, c->defs, c->ndefs, &sc, &err);
    if (st != SPC_OK)
        CHECK_MSG(sc == NULL && err.msg[0] != '\0', "%s: a failed load returned a scene or no message", c->path);
    spc_scene_destroy(sc);
    return st;
}

typedef struct render_ctx {
    spc_scene *sc;
    const char *integrator;
    const char *ckpt;
    bool aovs;
} render_ctx;

static spc_status op_render(void *p)
{
    render_ctx *c = p;
    spc_render_options o;
    spc_render_options_init(&o);
    o.spp = 2;
    o.threads = 2;
    o.aovs = c->aovs;
    o.integrator = c->integrator;
    o.checkpoint_path = c->ckpt;
    spc_film *film = NULL;
    spc_error err;
    spc_status st = spc_render(c->sc, &o, &film, NULL, &err);
    if (st == SPC_OK) {
        /* writing the images allocates too */
        char path[128];
        snprintf(path, sizeof path, "%s/out.exr", tmpdir);
        st = spc_film_write_exr(film, path, true, &err);
        snprintf(path, sizeof path, "%s/out.png", tmpdir);
        if (st == SPC_OK)
            st = spc_film_write_png(film, path, &err);
    }
    spc_film_destroy(film);
    return st;
}

static spc_status op_checkpoint_load(void *p)
{
    spc_checkpoint *c = NULL;
    spc_error err;
    spc_status st = spc_checkpoint_load((const char *)p, &c, &err);
    spc_checkpoint_destroy(c);
    return st;
}

static spc_status op_image_read(void *p)
{
    spc_image img;
    memset(&img, 0, sizeof img);
    spc_error err;
    spc_status st = spc_image_read((const char *)p, &img, &err);
    spc_image_release(&img);
    return st;
}

static spc_status op_image_rgb_read(void *p)
{
    spc_image_rgb img;
    memset(&img, 0, sizeof img);
    spc_error err;
    spc_status st = spc_image_rgb_read((const char *)p, &img, &err);
    spc_image_rgb_release(&img);
    return st;
}

/* ---- tests ---- */

TEST(scene_loading)
{
    spc_define defs[2] = {{"res", "8"}, {"spp", "2"}};
    char path[2200];
    const char *scenes[] = {"demo.xml", "shapes.xml", "textures.xml"};
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; ++i) {
        snprintf(path, sizeof path, "%s/%s", scene_path, scenes[i]);
        if (access(path, R_OK) != 0)
            continue;
        load_ctx c = {path, defs, 2};
        inject(scenes[i], op_load, &c, 4000);
    }
}

TEST(render_setup_and_writing)
{
    spc_define defs[1] = {{"res", "20"}};
    char path[2200];
    snprintf(path, sizeof path, "%s/demo.xml", scene_path);
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(path, defs, 1, &sc, &err) == SPC_OK);
    if (!sc)
        return;
    /* the scene's list of specular casters, built on first use and freed with the scene (the
     * default specular NEE plan reads it), made before the blocks are counted */
    free(spc_scene_plan(sc, NULL, NULL));
    char ckpt[128];
    snprintf(ckpt, sizeof ckpt, "%s/a.ckpt", tmpdir);
    render_ctx cases[] = {{sc, "path", NULL, false}, {sc, "ipt", NULL, true}, {sc, "path", ckpt, true}};
    const char *names[] = {"render path", "render ipt with AOVs (splats)", "render with a checkpoint"};
    for (int i = 0; i < 3; ++i)
        inject(names[i], op_render, &cases[i], 2000);
    inject("checkpoint load", op_checkpoint_load, ckpt, 200);
    char img[2200];
    snprintf(img, sizeof img, "%s/out.exr", tmpdir);
    inject("EXR read", op_image_read, img, 200);
    inject("EXR rgb+variance read", op_image_rgb_read, img, 200);
    snprintf(img, sizeof img, "%s/out.png", tmpdir);
    inject("PNG read", op_image_read, img, 200);
    snprintf(img, sizeof img, "%s/textures/blobs.jpg", scene_path);
    if (access(img, R_OK) == 0)
        inject("JPEG read", op_image_read, img, 200);
    spc_scene_destroy(sc);
}

int main(void)
{
    char cwd[1024];
    if (!getcwd(cwd, sizeof cwd))
        return 1;
    const char *src = spc_test_source_dir();
    snprintf(scene_path, sizeof scene_path, "%s%s%s/scenes", src[0] == '/' ? "" : cwd, src[0] == '/' ? "" : "/",
             src);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_allocfail_XXXXXX");
    if (!mkdtemp(tmpdir))
        return 1;
    spc_warn_set_quiet(1);
    RUN(scene_loading);
    RUN(render_setup_and_writing);
    const char *files[] = {"a.ckpt", "out.exr", "out.png"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; ++i) {
        char p[256];
        snprintf(p, sizeof p, "%s/%s", tmpdir, files[i]);
        unlink(p);
    }
    rmdir(tmpdir);
    return spc_test_finish();
}
