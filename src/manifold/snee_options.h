/*
 * manifold/snee_options.h: the grammar of a specular-NEE setting, written once.
 *
 * A setting is what --specular-nee and the integrator property specular_nee take:
 *
 *     ""  |  auto  |  auto:pilot  |  none  |  off  |  SOLVER[:OPTION[,OPTION...]]
 *
 * "" and auto let the scene choose (snee_plan.h), auto:pilot too, checked by a pilot render
 * (render/snee_pilot.h), none and off turn specular NEE off, SOLVER is a
 * name of the solver table (spc_specular_solver_parse: angular, newton, conic) and each OPTION is
 * one of the table below (spc_snee_options): a switch (NAME, or its negation noNAME), a value
 * (NAME=V) or a switch with an optional value (NAME[=V]). The one table drives the parser, the
 * canonical text of a parameter set (spc_snee_options_format), `specula render --help`
 * (spc_snee_options_help) and the messages that refuse a bad setting, which name the bad option and
 * list the valid ones. The defaults it shows are read from spc_snee_params_default, so they cannot
 * disagree with what runs.
 *
 * This header needs no other specula header: the scene loader checks a property with it without
 * knowing specular NEE's parameters.
 */
#ifndef SPC_MANIFOLD_SNEE_OPTIONS_H
#define SPC_MANIFOLD_SNEE_OPTIONS_H

#include <stdbool.h>
#include <stddef.h>

struct spc_snee_params;

/* The longest message spc_snee_options_parse writes (the valid options' list included: about 800
 * characters, with room for more options). */
#define SPC_SNEE_WHY_MAX 1024

typedef enum spc_snee_option_kind {
    SPC_SNEE_OPT_SWITCH, /* NAME (and its negation, if any); no value */
    SPC_SNEE_OPT_COUNT,  /* NAME=N, an integer in [lo, hi] */
    SPC_SNEE_OPT_REAL,   /* NAME=X, a number in the range (lo_open, hi_open: bounds excluded) */
    SPC_SNEE_OPT_CHOICE  /* NAME=WORD, WORD one of choices (its index is the enum value set) */
} spc_snee_option_kind;

/* No field (spc_snee_option.flag / .field). */
#define SPC_SNEE_NO_FIELD ((size_t)-1)

/* One option. Its effect on the parameters is data: NAME sets the bool at `flag` (if any) and the
 * value, when given, to the int or double at `field`; NAME alone without a flag sets `field` to
 * `implied`; the negation clears the flag, or without one sets the field to 0. */
typedef struct spc_snee_option {
    const char *name;
    const char *negation; /* the word that turns it off ("noreflect"), or NULL */
    spc_snee_option_kind kind;
    bool value_optional; /* NAME alone is valid too */
    const char *metavar; /* the value's name in the help: "N", "P", ... (NULL for a switch) */
    double lo, hi;       /* the value's range (COUNT, REAL) */
    bool lo_open, hi_open;
    const char *const *choices; /* CHOICE: NULL-terminated, in the enum's order */
    int solver;                 /* 0: every solver; else only this one (SPC_SNEE_NEWTON) */
    size_t flag;                /* offsetof the bool in spc_snee_params, or SPC_SNEE_NO_FIELD */
    size_t field;               /* offsetof the int, double or enum, or SPC_SNEE_NO_FIELD */
    double implied;             /* NAME alone without a flag: the value it sets */
    const char *default_note;   /* the default in words where the table's is not the whole story */
    const char *help;           /* what it does, one sentence */
} spc_snee_option;

/* The table, and its length in *n. */
const spc_snee_option *spc_snee_options(int *n);

typedef enum spc_snee_parse_result {
    SPC_SNEE_PARSE_OK,         /* parsed */
    SPC_SNEE_PARSE_BAD_SOLVER, /* the name before ':' is no solver */
    SPC_SNEE_PARSE_BAD_OPTION  /* an unknown option, a bad or missing value, options that exclude each other */
} spc_snee_parse_result;

/* Parses a setting SOLVER[:OPTIONS] (not the plan's words auto and off; "" and none are the solver
 * none): *p = spc_snee_params_default(p, solver, max_chain), then each option in turn. On failure (p
 * undefined) a message in why (at most why_len bytes, SPC_SNEE_WHY_MAX is enough) names the bad
 * solver, option or value and lists the valid ones. why may be NULL. */
spc_snee_parse_result spc_snee_options_parse(const char *setting, int max_chain, struct spc_snee_params *p, char *why,
                                             size_t why_len);

/* Checks a setting as a scene file or the command line gives it: the plan's words too. The result
 * and message as spc_snee_options_parse's. */
spc_snee_parse_result spc_snee_setting_check(const char *setting, char *why, size_t why_len);

/* The plan's words: "", NULL, auto and auto:pilot choose from the scene (auto:pilot also checks the
 * plan's choice by a pilot render: render/snee_pilot.h); none and off turn specular NEE off. */
bool spc_snee_setting_is_auto(const char *setting);
bool spc_snee_setting_pilot(const char *setting); /* auto:pilot: the pilot render runs */
bool spc_snee_setting_is_off(const char *setting);

/* Writes the canonical setting of p (solver and every option of the table that applies to it, in
 * the table's order) to buf (always terminated); spc_snee_options_parse reads it back to the same
 * parameters. Returns the length it needed (as snprintf). */
int spc_snee_options_format(const struct spc_snee_params *p, char *buf, size_t len);

/* The settings' help for `specula render --help`: one paragraph per option, each line starting with
 * `indent` spaces, at most `width` columns. The caller frees it; NULL if out of memory. */
char *spc_snee_options_help(int indent, int width);

/* Parses a specular-NEE setting SOLVER[:OPTION[,OPTION...]], e.g. "newton:biased=8,seed=light":
 * spc_snee_options_parse (snee_options.h, where the options' one table is) without the message.
 * False (p undefined) for an unknown name or option, or a bad value. */
bool spc_snee_parse(const char *spec, int max_chain, struct spc_snee_params *p);

#endif
