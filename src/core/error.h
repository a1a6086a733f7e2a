/*
 * core/error.h: status codes and the error record of the loading, I/O and public API tier.
 *
 * Hot paths (sample, eval, solve) never use these: they report "no sample" with a zero weight, a
 * zero pdf or false. The library never calls exit(); it fills a spc_error and returns its code.
 */
#ifndef SPC_CORE_ERROR_H
#define SPC_CORE_ERROR_H

#include <stdarg.h>

typedef enum spc_status {
    SPC_OK = 0,          /* success */
    SPC_ERR_IO = 1,      /* a file could not be opened, read or written */
    SPC_ERR_PARSE = 2,   /* malformed input: XML syntax, OBJ/PLY/EXR/PNG content */
    SPC_ERR_PLUGIN = 3,  /* an unknown plugin type or an integrator specula does not have */
    SPC_ERR_VALUE = 4,   /* a well-formed but invalid value: negative radius, NaN vertex, bad index */
    SPC_ERR_NOMEM = 5,   /* an allocation failed */
    SPC_ERR_LIMIT = 6,   /* a size beyond what specula accepts (film, sample count) */
    SPC_ERR_ACCEL = 7,   /* Embree refused the device or the scene */
    SPC_ERR_INTERNAL = 8 /* a broken invariant: a bug in specula */
} spc_status;

#define SPC_ERROR_MSG_MAX 1024

/* Details of the last failure: "file:line:col: message". line/col are 0 when unknown. */
typedef struct spc_error {
    spc_status code;
    char file[512];
    int line, col;
    char msg[SPC_ERROR_MSG_MAX];
} spc_error;

/* Fills err (if not NULL) and returns code. file may be NULL. */
spc_status spc_error_set(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 6, 7)))
#endif
    ;
spc_status spc_error_setv(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt,
                          va_list ap);
/* Writes "file:line:col: message" (parts omitted when unknown) into buf. */
void spc_error_format(const spc_error *err, char *buf, int size);
const char *spc_status_name(spc_status code);

/* Warnings (unknown properties, ...): printed to stderr as "file:line:col: warning: ...". */
void spc_warn(const char *file, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;
/* Silence warnings (tests); returns the previous setting. */
int spc_warn_set_quiet(int quiet);

/* Invariants: SPC_CHECK is always on and cheap; SPC_DCHECK only in debug builds. */
void spc_check_failed(const char *expr, const char *file, int line);
#define SPC_CHECK(x) ((x) ? (void)0 : spc_check_failed(#x, __FILE__, __LINE__))
#ifdef NDEBUG
#define SPC_DCHECK(x) ((void)0)
#else
#define SPC_DCHECK(x) SPC_CHECK(x)
#endif

#endif
