/*
 * render/snee_pilot.c: the pilot render that keeps or turns off the automatic specular NEE plan
 * (snee_pilot.h has the method and its reasons). Each candidate's groups are ordinary renders
 * through the render loop below spc_render (render/driver.h: one thread, the candidate's explicit
 * setting, no pilot) of a small image, whose films hold each pixel's sum and sum of squares: the
 * per-sample variance of every pixel, the camera query's splats included.
 */
#include "render/snee_pilot.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/math.h"
#include "render/driver.h"
#include "render/film.h"
#include "scene/scene.h"

/* The bench's relMSE guard: a pixel's error is taken relative to m^2 + this (bench_default.py). */
#define SPC_SNEE_PILOT_GUARD 0.01
/* The pilot's first group's samples per pixel (a variance needs two). */
#define SPC_SNEE_PILOT_SPP0 2
/* The groups' seeds: SEED + group (any fixed value; not the render's seeds 0, 1, ...). */
#define SPC_SNEE_PILOT_SEED 0x9e3779b9u
/* More samples per pixel per group than any pilot needs. */
#define SPC_SNEE_PILOT_SPP_MAX 256

static double thread_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* One group: renders setting at the pilot size with spp samples per pixel and seed, on this
 * thread; *film the result (the caller destroys it), *sec its CPU time. false if it failed. */
static bool group_render(const spc_scene *sc, const spc_render_options *o, const char *setting, int w, int h,
                         int spp, uint64_t seed, spc_film **film, double *sec)
{
    spc_render_options g;
    spc_render_options_init(&g);
    g.integrator = o->integrator;
    g.max_depth = o->max_depth;
    g.mis_balance = o->mis_balance;
    g.specular_nee = setting;
    g.width = w;
    g.height = h;
    g.spp = spp;
    g.seed = seed;
    g.threads = 1;
    spc_render_stats st;
    spc_error err;
    double t0 = thread_seconds();
    spc_snee_plan plan;
    spc_driver_plan(sc, &g, &plan);
    spc_status s = spc_driver_render(sc, &g, &plan, film, &st, &err);
    *sec = thread_seconds() - t0;
    return s == SPC_OK && *film;
}

/* The render's pixels. */
static double render_pixels(const spc_scene *sc, const spc_render_options *o)
{
    if (o->width > 0 && o->height > 0)
        return (double)o->width * o->height;
    if (sc->film.crop_w > 0 && sc->film.crop_h > 0)
        return (double)sc->film.crop_w * sc->film.crop_h;
    return (double)sc->film.width * sc->film.height;
}

/* The render's size in camera samples (its pixels x spp), or 0 under a time limit. */
static double render_samples(const spc_scene *sc, const spc_render_options *o)
{
    double px = render_pixels(sc, o);
    if (o->time_limit > 0.0 && o->spp <= 0)
        return 0.0;
    double spp = o->spp > 0 ? o->spp : sc->spp;
    return px * (spp > 0 ? spp : 1.0);
}

/* A pixel channel's error scale over the whole pilot image: (m^2 + guard) x its values, m the mean
 * of every candidate's samples (all estimate the same image). */
static double pixel_norm(double *const *sum, const double *n, int nc, size_t i)
{
    double s = 0.0, k = 0.0;
    for (int c = 0; c < nc; ++c) {
        s += sum[c][i];
        k += n[c];
    }
    double m = s / k;
    return m * m + SPC_SNEE_PILOT_GUARD;
}

void spc_snee_pilot_run(const spc_scene *sc, const spc_render_options *o, spc_snee_plan *plan, spc_snee_pilot *out)
{
    memset(out, 0, sizeof *out);
    if (!plan->automatic || !plan->on || !plan->pilot)
        return;
    /* the pilot image: the film's aspect, SPC_SNEE_PILOT_EDGE on the longer side */
    double fw = o->width > 0 ? o->width : sc->film.width, fh = o->height > 0 ? o->height : sc->film.height;
    if (!(fw > 0.0) || !(fh > 0.0))
        return;
    double sc_edge = SPC_SNEE_PILOT_EDGE / (fw > fh ? fw : fh);
    if (sc_edge > 1.0)
        sc_edge = 1.0;
    int w = (int)lround(fw * sc_edge), h = (int)lround(fh * sc_edge);
    w = w < 1 ? 1 : w;
    h = h < 1 ? 1 : h;
    const int nc = SPC_SNEE_PILOT_CANDIDATES;
    snprintf(out->cand[0].setting, sizeof out->cand[0].setting, "none");
    snprintf(out->cand[1].setting, sizeof out->cand[1].setting, "%s", plan->setting);
    out->ncand = nc;
    out->width = w;
    out->height = h;
    out->groups = SPC_SNEE_PILOT_GROUPS;

    size_t npix = (size_t)w * (size_t)h;
    /* per candidate: every group's sums pooled, and the sample count per pixel */
    double *sum[SPC_SNEE_PILOT_CANDIDATES], *sumsq[SPC_SNEE_PILOT_CANDIDATES];
    double sec[SPC_SNEE_PILOT_CANDIDATES] = {0}, n[SPC_SNEE_PILOT_CANDIDATES] = {0};
    /* and each group's per-sample variance, per pixel and channel */
    double *gvar[SPC_SNEE_PILOT_CANDIDATES][SPC_SNEE_PILOT_GROUPS] = {{NULL}};
    bool ok = true;
    for (int c = 0; c < nc; ++c) {
        sum[c] = calloc(3 * npix, sizeof(double));
        sumsq[c] = calloc(3 * npix, sizeof(double));
        ok = ok && sum[c] && sumsq[c];
        for (int g = 0; g < SPC_SNEE_PILOT_GROUPS; ++g)
            ok = ok && (gvar[c][g] = calloc(3 * npix, sizeof(double))) != NULL;
    }
    int spp[SPC_SNEE_PILOT_CANDIDATES];
    for (int c = 0; c < nc; ++c)
        spp[c] = SPC_SNEE_PILOT_SPP0;
    for (int g = 0; ok && g < SPC_SNEE_PILOT_GROUPS; ++g) {
        if (g == 1) {
            /* the later groups' sizes from the first group's costs: equal CPU time per candidate,
             * all of them together the pilot's share of the render */
            double cheap = INFINITY;
            for (int c = 0; c < nc; ++c)
                cheap = spc_min(cheap, sec[c] / (n[c] * (double)npix));
            double rs = render_samples(sc, o);
            double render_sec = rs > 0.0 ? rs * cheap : o->time_limit * (o->threads > 0 ? o->threads : 1);
            double budget = spc_min(spc_max(SPC_SNEE_PILOT_SHARE * render_sec, SPC_SNEE_PILOT_MIN_SECONDS),
                                    SPC_SNEE_PILOT_MAX_SECONDS);
            double left = budget - out->seconds;
            for (int c = 0; c < nc; ++c) {
                double per = left / ((double)nc * (SPC_SNEE_PILOT_GROUPS - 1) * (sec[c] / n[c]));
                spp[c] = per > SPC_SNEE_PILOT_SPP_MAX ? SPC_SNEE_PILOT_SPP_MAX : (int)per;
                if (spp[c] < SPC_SNEE_PILOT_SPP0)
                    spp[c] = SPC_SNEE_PILOT_SPP0;
            }
        }
        for (int c = 0; ok && c < nc; ++c) {
            double t = 0.0;
            spc_film *f = NULL;
            ok = group_render(sc, o, out->cand[c].setting, w, h, spp[c], SPC_SNEE_PILOT_SEED + (uint64_t)g, &f, &t);
            if (ok) {
                sec[c] += t;
                n[c] += f->spp;
                out->seconds += t;
                double k = f->spp;
                for (size_t i = 0; i < 3 * npix; ++i) {
                    sum[c][i] += f->sum[i];
                    sumsq[c][i] += f->sumsq[i];
                    gvar[c][g][i] = spc_max(0.0, (f->sumsq[i] - f->sum[i] * f->sum[i] / k) / (k - 1.0));
                }
            }
            spc_film_destroy(f);
        }
    }
    if (ok) {
        for (int c = 0; c < nc; ++c) {
            out->cand[c].sec_per_sample = sec[c] / (n[c] * (double)npix);
            out->cand[c].spp = (int)n[c];
        }
        /* the render's samples per pixel with each candidate at equal CPU time: the plan's at the
         * render's own count (or its time limit), the others at the same CPU time */
        double rpix = render_pixels(sc, o), rs = render_samples(sc, o);
        double T = rs > 0.0 ? rs * out->cand[1].sec_per_sample : o->time_limit * (o->threads > 0 ? o->threads : 1);
        double N[SPC_SNEE_PILOT_CANDIDATES];
        for (int c = 0; c < nc; ++c)
            N[c] = spc_max(n[c], T / (rpix * out->cand[c].sec_per_sample));
        /* the tail factor: each candidate's largest group variance over its groups' mean */
        double gsum[SPC_SNEE_PILOT_CANDIDATES][SPC_SNEE_PILOT_GROUPS] = {{0}};
        for (size_t i = 0; i < 3 * npix; ++i) {
            double norm = pixel_norm(sum, n, nc, i);
            for (int c = 0; c < nc; ++c)
                for (int g = 0; g < SPC_SNEE_PILOT_GROUPS; ++g)
                    gsum[c][g] += gvar[c][g][i] / norm;
        }
        for (int c = 0; c < nc; ++c) {
            double mx = 0.0, mean = 0.0;
            for (int g = 0; g < SPC_SNEE_PILOT_GROUPS; ++g) {
                mx = spc_max(mx, gsum[c][g]);
                mean += gsum[c][g] / SPC_SNEE_PILOT_GROUPS;
            }
            out->cand[c].tail = mean > 0.0 ? mx / mean : 1.0;
        }
        for (size_t i = 0; i < 3 * npix; ++i) {
            double m[SPC_SNEE_PILOT_CANDIDATES], v[SPC_SNEE_PILOT_CANDIDATES];
            for (int c = 0; c < nc; ++c) {
                m[c] = sum[c][i] / n[c];
                v[c] = spc_max(0.0, (sumsq[c][i] - sum[c][i] * m[c]) / (n[c] - 1.0));
            }
            double norm = pixel_norm(sum, n, nc, i) * 3.0 * (double)npix;
            for (int c = 0; c < nc; ++c) {
                int o2 = 1 - c;
                /* the lower mean's deficit beyond both means' noise: mass its tail has not shown in
                 * n samples, so found with a probability p below about 1/n; a render of N samples
                 * keeps between n/N (p ~ 1/n) and all (p << 1/N) of its square: sqrt(n/N) of it */
                double d = m[o2] - m[c];
                double deficit = d > 0.0 ? spc_max(0.0, d * d - v[c] / n[c] - v[o2] / n[o2]) : 0.0;
                out->cand[c].rel_var_plain += v[c] / norm;
                out->cand[c].deficit += deficit / norm;
                out->cand[c].score += (v[c] * out->cand[c].tail / N[c] + deficit * sqrt(n[c] / N[c])) / norm;
            }
        }
        out->ran = true;
        out->chosen = out->cand[1].score * SPC_SNEE_PILOT_MARGIN < out->cand[0].score ? 1 : 0;
        const spc_snee_pilot_candidate *a = &out->cand[0], *b = &out->cand[1];
        snprintf(plan->pilot_note, sizeof plan->pilot_note,
                 "pilot %dx%d, %.3g CPU-s: none %d spp, %.3g us/sample, variance %.3g (tail %.2g), deficit %.3g; "
                 "%s %d spp, %.3g us/sample, variance %.3g (tail %.2g), deficit %.3g; relMSE at equal time, none / "
                 "plan %.3g: %s",
                 w, h, out->seconds, a->spp, 1e6 * a->sec_per_sample, a->rel_var_plain, a->tail, a->deficit, b->setting,
                 b->spp, 1e6 * b->sec_per_sample, b->rel_var_plain, b->tail, b->deficit,
                 b->score > 0.0 ? a->score / b->score : INFINITY, out->chosen ? "kept" : "off");
        if (!out->chosen) {
            plan->on = false;
            snprintf(plan->setting, sizeof plan->setting, "none");
            snprintf(plan->reason, sizeof plan->reason, "the pilot render measured it no cheaper than none");
        }
    }
    for (int c = 0; c < nc; ++c) {
        free(sum[c]);
        free(sumsq[c]);
        for (int g = 0; g < SPC_SNEE_PILOT_GROUPS; ++g)
            free(gvar[c][g]);
    }
}
