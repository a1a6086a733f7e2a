/*
 * core/error.h: status codes and the error record of the loading, I/O and public API tier.
 *
 * Hot paths (sample, eval, solve) never use these: they report "no sample" with a zero weight, a
 * zero pdf or false. The library never calls exit(); it fills a spc_error and returns its code.
 */
#ifndef SPC_CORE_ERROR_H
#define SPC_CORE_ERROR_H

#include <stdarg.h>

#include "specula/specula.h" /* spc_status, spc_error, spc_error_format, spc_status_name */

/* Fills err (if not NULL) and returns code. file may be NULL. */
spc_status spc_error_set(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 6, 7)))
#endif
    ;
spc_status spc_error_setv(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt,
                          va_list ap);

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
