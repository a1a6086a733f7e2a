/*
 * tests/test_snee_options.c: the one table of specular NEE's options (manifold/snee_options.h)
 * drives the parser, the canonical text, the help and the errors:
 *   - every option of the table, with every kind of value it takes and its negation, parses for
 *     every solver it applies to, changes the parameters for at least one of its values, and
 *     round-trips: the canonical text parses back to the same parameters and prints the same;
 *   - every option, its negation and its default (read from spc_snee_params_default) appear in
 *     `specula render --help`;
 *   - bad settings are refused with a message naming the bad part and, for an unknown option,
 *     listing every valid one: by the parser, by `specula render --specular-nee` (exit 4, or 3 for an
 *     unknown solver) and by the scene loader at the property's file:line:col.
 */
/* ctest-labels: unit */
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "cli_util.h"
#include "harness.h"
#include "manifold/snee_options.h"
#include "manifold/specular_nee.h"
#include "specula/specula.h"

static const int solvers[] = {SPC_SNEE_ANGULAR, SPC_SNEE_NEWTON, SPC_SNEE_CONIC};
#define NSOLVERS ((int)(sizeof solvers / sizeof solvers[0]))

/* The settings that exercise option o: the name alone (where valid), each bound and an inner value
 * of its range, every choice, the negation. Returns how many were written to out. */
static int option_settings(const spc_snee_option *o, char out[][64], int max)
{
    int n = 0;
    if (o->kind == SPC_SNEE_OPT_SWITCH || o->value_optional)
        snprintf(out[n++], 64, "%s", o->name);
    if (o->negation)
        snprintf(out[n++], 64, "%s", o->negation);
    switch (o->kind) {
    case SPC_SNEE_OPT_COUNT:
        snprintf(out[n++], 64, "%s=%d", o->name, (int)o->lo);
        snprintf(out[n++], 64, "%s=%d", o->name, (int)o->hi);
        snprintf(out[n++], 64, "%s=%d", o->name, (int)(o->lo + 1 < o->hi ? o->lo + 1 : o->hi));
        break;
    case SPC_SNEE_OPT_REAL:
        snprintf(out[n++], 64, "%s=%.17g", o->name, o->lo + 0.37 * (o->hi - o->lo));
        if (!o->hi_open)
            snprintf(out[n++], 64, "%s=%.17g", o->name, o->hi);
        if (!o->lo_open)
            snprintf(out[n++], 64, "%s=%.17g", o->name, o->lo);
        break;
    case SPC_SNEE_OPT_CHOICE:
        for (int i = 0; o->choices[i] && n < max; ++i)
            snprintf(out[n++], 64, "%s=%s", o->name, o->choices[i]);
        break;
    case SPC_SNEE_OPT_SWITCH:
        break;
    }
    return n;
}

TEST(every_option_parses_and_round_trips)
{
    int nopt;
    const spc_snee_option *opts = spc_snee_options(&nopt);
    CHECK(nopt >= 15);
    for (int i = 0; i < nopt; ++i) {
        const spc_snee_option *o = &opts[i];
        char settings[12][64];
        int ns = option_settings(o, settings, 12);
        bool changes = false;
        for (int s = 0; s < NSOLVERS; ++s) {
            if (o->solver && o->solver != solvers[s])
                continue;
            const spc_specular_solver *sv = spc_specular_solver_get(solvers[s]);
            CHECK(sv != NULL);
            if (!sv)
                continue;
            spc_snee_params def;
            spc_snee_params_default(&def, solvers[s], 2);
            for (int k = 0; k < ns; ++k) {
                char spec[128], why[SPC_SNEE_WHY_MAX] = "";
                snprintf(spec, sizeof spec, "%.32s:%.63s", sv->name, settings[k]);
                spc_snee_params p, q;
                spc_snee_parse_result r = spc_snee_options_parse(spec, 2, &p, why, sizeof why);
                CHECK_MSG(r == SPC_SNEE_PARSE_OK, "'%s' refused: %s", spec, why);
                if (r != SPC_SNEE_PARSE_OK)
                    continue;
                changes = changes || memcmp(&p, &def, sizeof p) != 0;
                char text[1024], text2[1024];
                int len = spc_snee_options_format(&p, text, sizeof text);
                CHECK(len > 0 && len < (int)sizeof text);
                r = spc_snee_options_parse(text, 2, &q, why, sizeof why);
                CHECK_MSG(r == SPC_SNEE_PARSE_OK, "'%s' (from '%s') refused: %s", text, spec, why);
                CHECK_MSG(r == SPC_SNEE_PARSE_OK && memcmp(&p, &q, sizeof p) == 0,
                          "'%s' read back from '%s' gives other parameters", text, spec);
                spc_snee_options_format(&q, text2, sizeof text2);
                CHECK_MSG(!strcmp(text, text2), "'%s' printed again as '%s'", text, text2);
                /* the old entry point reads the same */
                CHECK(spc_snee_parse(spec, 2, &q) && memcmp(&p, &q, sizeof p) == 0);
            }
        }
        CHECK_MSG(changes, "no setting of option '%s' changes the parameters", o->name);
    }
    /* a few values read back as written */
    spc_snee_params p;
    CHECK(spc_snee_options_parse("angular:trials=7,seed=light,reflect=0.3,camera=0.25,receivers=2,chain=3", 2, &p, NULL,
                                 0) == SPC_SNEE_PARSE_OK);
    CHECK(p.max_trials == 7 && p.seed == SPC_SNEE_SEED_LIGHT && p.reflect && p.reflect_p == 0.3 && p.camera &&
          p.camera_p == 0.25 && p.receivers == 2 && p.max_chain == 3);
    CHECK(spc_snee_options_parse("newton:constraint=half,rough", 2, &p, NULL, 0) == SPC_SNEE_PARSE_OK &&
          p.newton.constraint == SPC_NEWTON_HALF_VECTOR && p.newton.rough && !p.reflect && !p.exact);
    /* defaults: every solver's canonical text reads back to its defaults */
    for (int s = 0; s < NSOLVERS; ++s) {
        spc_snee_params def, q;
        spc_snee_params_default(&def, solvers[s], 2);
        char text[1024];
        spc_snee_options_format(&def, text, sizeof text);
        CHECK_MSG(spc_snee_options_parse(text, 2, &q, NULL, 0) == SPC_SNEE_PARSE_OK && !memcmp(&def, &q, sizeof q),
                  "defaults '%s'", text);
    }
    /* the setting's words */
    const char *words[] = {"", "auto", "off", "none", "angular", "newton:rough", NULL};
    for (int i = 0; words[i]; ++i)
        CHECK_MSG(spc_snee_setting_check(words[i], NULL, 0) == SPC_SNEE_PARSE_OK, "'%s'", words[i]);
}

/* Does the help name every option and negation, with the defaults spc_snee_params_default has? */
static void check_help_text(const char *help, const char *what)
{
    int nopt;
    const spc_snee_option *opts = spc_snee_options(&nopt);
    for (int i = 0; i < nopt; ++i) {
        char line[80];
        snprintf(line, sizeof line, "\n  %s", opts[i].name);
        CHECK_MSG(strstr(help, line) != NULL, "%s lacks option '%s'", what, opts[i].name);
        if (opts[i].negation) {
            snprintf(line, sizeof line, ", %s", opts[i].negation);
            CHECK_MSG(strstr(help, line) != NULL, "%s lacks '%s'", what, opts[i].negation);
        }
    }
    /* defaults that differ between solvers, as the parameters have them */
    spc_snee_params a, n;
    spc_snee_params_default(&a, SPC_SNEE_ANGULAR, 2);
    spc_snee_params_default(&n, SPC_SNEE_NEWTON, 2);
    char want[96];
    snprintf(want, sizeof want, "%d (angular)", a.max_trials);
    CHECK_MSG(strstr(help, want) != NULL, "%s lacks the default '%s'", what, want);
    snprintf(want, sizeof want, "%d (newton", n.max_trials);
    CHECK_MSG(strstr(help, want) != NULL, "%s lacks the default '%s'", what, want);
    snprintf(want, sizeof want, "(default: long=%g)", a.long_p);
    CHECK_MSG(strstr(help, want) != NULL, "%s lacks the default '%s'", what, want);
}

TEST(help_lists_every_option)
{
    char *help = spc_specular_nee_help(2, 96);
    CHECK(help != NULL);
    if (help) {
        char *text = malloc(strlen(help) + 2); /* each option at a line's start */
        if (text) {
            text[0] = '\n';
            strcpy(text + 1, help);
            check_help_text(text, "spc_specular_nee_help");
        }
        free(text);
        /* no line past the width */
        for (const char *l = help; *l;) {
            size_t n = strcspn(l, "\n");
            CHECK_MSG(n <= 96, "help line of %zu columns", n);
            l += n + (l[n] == '\n');
        }
    }
    free(help);
    CHECK(run("render", "--help", NULL) == 0);
    char *out = read_text("out.txt");
    CHECK(out != NULL);
    if (out)
        check_help_text(out, "specula render --help");
    free(out);
}

TEST(bad_settings_refused)
{
    struct {
        const char *spec, *says[3];
        spc_snee_parse_result r;
    } bad[] = {
        {"angular:frobnicate",
         {"unknown specular NEE option 'frobnicate'", "valid options: ", "sneep=Q"},
         SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:trials=0", {"'trials'", "'0'", "from 1 to"}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:trials", {"'trials' needs a value", "trials=N", NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:reflect=1", {"'reflect'", "(0, 1)", NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:seed=sun", {"'seed'", "shape|light|bsdf|cone", NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:rough", {"'rough'", "newton", NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:nomis=1", {"'nomis' takes no value", NULL, NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"newton:rough,exact", {"'rough' excludes 'exact'", NULL, NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"none:trials=3", {"need a solver", NULL, NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angular:", {"unknown specular NEE option ''", NULL, NULL}, SPC_SNEE_PARSE_BAD_OPTION},
        {"angualr", {"unknown specular NEE solver 'angualr'", "angular", "newton"}, SPC_SNEE_PARSE_BAD_SOLVER},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        spc_snee_params p;
        char why[SPC_SNEE_WHY_MAX] = "";
        spc_snee_parse_result r = spc_snee_options_parse(bad[i].spec, 2, &p, why, sizeof why);
        CHECK_MSG(r == bad[i].r, "'%s': result %d", bad[i].spec, (int)r);
        for (int k = 0; k < 3 && bad[i].says[k]; ++k)
            CHECK_MSG(strstr(why, bad[i].says[k]), "'%s': '%s' lacks '%s'", bad[i].spec, why, bad[i].says[k]);
        CHECK(!spc_snee_parse(bad[i].spec, 2, &p));
    }
    /* an unknown option's message lists every option of the table */
    spc_snee_params p;
    char why[SPC_SNEE_WHY_MAX] = "";
    spc_snee_options_parse("conic:x", 2, &p, why, sizeof why);
    int nopt;
    const spc_snee_option *opts = spc_snee_options(&nopt);
    for (int i = 0; i < nopt; ++i)
        CHECK_MSG(strstr(why, opts[i].name), "'%s' lacks '%s'", why, opts[i].name);

    /* the command line */
    static const char scene_fmt[] =
        "<scene version=\"3.0.0\">\n"
        "  <integrator type=\"path\">\n"
        "    <integer name=\"max_depth\" value=\"3\"/>\n"
        "    <string name=\"specular_nee\" value=\"%s\"/>\n"
        "  </integrator>\n"
        "  <sensor type=\"perspective\">\n"
        "    <film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" "
        "value=\"4\"/></film>\n"
        "  </sensor>\n"
        "  <shape type=\"rectangle\"><bsdf type=\"diffuse\"/></shape>\n"
        "  <shape type=\"sphere\"><point name=\"center\" x=\"0\" y=\"0\" z=\"1\"/><float name=\"radius\" "
        "value=\"0.3\"/>\n"
        "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n"
        "</scene>\n";
    char xml[2048];
    snprintf(xml, sizeof xml, scene_fmt, "auto");
    CHECK(write_file("ok.xml", xml));
    CHECK(run("render", "ok.xml", "-o", "a.exr", "--spp", "1", "--quiet", "--specular-nee", "angular:trials=8", NULL) ==
          0);
    CHECK(run("render", "ok.xml", "-o", "b.exr", "--spp", "1", "--quiet", "--specular-nee", "angular:trails=8", NULL) ==
          SPC_ERR_VALUE);
    CHECK(err_has("--specular-nee 'angular:trails=8': unknown specular NEE option 'trails=8'"));
    CHECK(err_has("valid options: ") && err_has("trials=N"));
    CHECK(!exists("b.exr"));
    CHECK(run("render", "ok.xml", "-o", "b.exr", "--spp", "1", "--quiet", "--specular-nee", "angular:camera=2", NULL) ==
          SPC_ERR_VALUE);
    CHECK(err_has("bad value '2' of specular NEE option 'camera': a number in (0, 1]"));
    CHECK(run("render", "ok.xml", "-o", "b.exr", "--spp", "1", "--quiet", "--specular-nee", "glass", NULL) ==
          SPC_ERR_PLUGIN);
    CHECK(err_has("unknown specular NEE solver 'glass'"));

    /* the scene file: the property's file:line:col, by the loader and by the command */
    snprintf(xml, sizeof xml, scene_fmt, "newton:constraint=half,seed=cone,guide=200");
    CHECK(write_file("bad.xml", xml));
    spc_scene *sc = NULL;
    spc_error err;
    CHECK(spc_scene_load(tmp_path("bad.xml"), NULL, 0, &sc, &err) == SPC_ERR_VALUE && !sc);
    CHECK_MSG(err.line == 4 && err.col > 0, "line %d col %d", err.line, err.col);
    CHECK_MSG(strstr(err.msg, "bad value '200' of specular NEE option 'guide': a number in (0, 100]"), "%s", err.msg);
    spc_scene_destroy(sc);
    CHECK(run("render", "bad.xml", "-o", "b.exr", "--spp", "1", "--quiet", NULL) == SPC_ERR_VALUE);
    CHECK(err_has("bad.xml:4:") && err_has("specular_nee 'newton:constraint=half,seed=cone,guide=200'"));
    snprintf(xml, sizeof xml, scene_fmt, "angular:constraint=half");
    CHECK(write_file("bad2.xml", xml));
    CHECK(run("render", "bad2.xml", "-o", "b.exr", "--spp", "1", "--quiet", NULL) == SPC_ERR_VALUE);
    CHECK(err_has("bad2.xml:4:") && err_has("'constraint' is the newton solver's, not angular's"));
    snprintf(xml, sizeof xml, scene_fmt, "angular:long=0.5,mispsi=0.2");
    CHECK(write_file("good.xml", xml));
    CHECK(run("render", "good.xml", "-o", "g.exr", "--spp", "1", "--quiet", NULL) == 0);

    /* a long setting runs whole (the stats record every character), a too long one is refused,
     * never cut: a cut setting would run other options than those given */
    char longer[SPC_SPECULAR_NEE_MAX + 64];
    int n = snprintf(longer, sizeof longer, "angular:");
    for (int k = 0; k < 19; ++k)
        n += snprintf(longer + n, sizeof longer - (size_t)n, "first=0.1,");
    snprintf(longer + n, sizeof longer - (size_t)n, "later=0.1");
    CHECK(strlen(longer) > 150 && strlen(longer) < SPC_SPECULAR_NEE_MAX);
    CHECK(run("render", "ok.xml", "-o", "l.exr", "--spp", "1", "--quiet", "--stats", "l.json", "--specular-nee",
              longer, NULL) == 0);
    char *json = read_text("l.json");
    CHECK_MSG(json && strstr(json, longer), "the stats lack the whole setting: %s", json ? json : "(none)");
    free(json);
    n = (int)strlen(longer);
    for (; n < SPC_SPECULAR_NEE_MAX + 20; n += 10)
        memcpy(longer + n, ",first=0.1", 11);
    CHECK(run("render", "ok.xml", "-o", "m.exr", "--spp", "1", "--quiet", "--specular-nee", longer, NULL) != 0);
    CHECK(err_has("--specular-nee is ") && err_has("characters long (at most 255)"));
    CHECK(!exists("m.exr"));
    CHECK(run("info", "ok.xml", "--specular-nee", longer, NULL) != 0);
    CHECK(err_has("characters long (at most 255)"));
    /* the library refuses it too */
    spc_scene *ok = NULL;
    CHECK(spc_scene_load(tmp_path("ok.xml"), NULL, 0, &ok, &err) == SPC_OK);
    if (ok) {
        spc_render_options o;
        spc_render_options_init(&o);
        o.spp = 1;
        o.threads = 1;
        o.specular_nee = longer;
        spc_film *f = NULL;
        CHECK(spc_render(ok, &o, &f, NULL, &err) == SPC_ERR_VALUE && !f);
        CHECK_MSG(strstr(err.msg, "characters long"), "%s", err.msg);
        spc_film_destroy(f);
        spc_scene_destroy(ok);
    }
}

int main(void)
{
    if (!cli_init("snee_options")) {
        printf("0 passed, 1 failed\n");
        return 1;
    }
    RUN(every_option_parses_and_round_trips);
    RUN(help_lists_every_option);
    RUN(bad_settings_refused);
    return cli_finish(spc_test_finish());
}
