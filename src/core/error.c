/*
 * core/error.c: the error record, warnings and invariant failures.
 */
#include "core/error.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int warn_quiet = 0;

spc_status spc_error_setv(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt,
                          va_list ap)
{
    if (!err)
        return code;
    err->code = code;
    err->file[0] = '\0';
    if (file)
        snprintf(err->file, sizeof err->file, "%s", file);
    err->line = line;
    err->col = col;
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    return code;
}

spc_status spc_error_set(spc_error *err, spc_status code, const char *file, int line, int col, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    spc_error_setv(err, code, file, line, col, fmt, ap);
    va_end(ap);
    return code;
}

void spc_error_format(const spc_error *err, char *buf, int size)
{
    if (!err || size <= 0)
        return;
    if (err->file[0] && err->line > 0 && err->col > 0)
        snprintf(buf, (size_t)size, "%s:%d:%d: %s", err->file, err->line, err->col, err->msg);
    else if (err->file[0] && err->line > 0)
        snprintf(buf, (size_t)size, "%s:%d: %s", err->file, err->line, err->msg);
    else if (err->file[0])
        snprintf(buf, (size_t)size, "%s: %s", err->file, err->msg);
    else
        snprintf(buf, (size_t)size, "%s", err->msg);
}

const char *spc_status_name(spc_status code)
{
    switch (code) {
    case SPC_OK: return "ok";
    case SPC_ERR_IO: return "i/o error";
    case SPC_ERR_PARSE: return "parse error";
    case SPC_ERR_PLUGIN: return "unknown plugin";
    case SPC_ERR_VALUE: return "invalid value";
    case SPC_ERR_NOMEM: return "out of memory";
    case SPC_ERR_LIMIT: return "limit exceeded";
    case SPC_ERR_ACCEL: return "acceleration structure error";
    case SPC_ERR_INTERNAL: return "internal error";
    case SPC_ERR_INTERRUPTED: return "interrupted";
    }
    return "unknown status";
}

int spc_warn_set_quiet(int quiet)
{
    int old = warn_quiet;
    warn_quiet = quiet;
    return old;
}

void spc_warn(const char *file, int line, int col, const char *fmt, ...)
{
    if (warn_quiet)
        return;
    char msg[SPC_ERROR_MSG_MAX];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (file && line > 0 && col > 0)
        fprintf(stderr, "%s:%d:%d: warning: %s\n", file, line, col, msg);
    else if (file && line > 0)
        fprintf(stderr, "%s:%d: warning: %s\n", file, line, msg);
    else if (file)
        fprintf(stderr, "%s: warning: %s\n", file, msg);
    else
        fprintf(stderr, "warning: %s\n", msg);
}

void spc_check_failed(const char *expr, const char *file, int line)
{
    fprintf(stderr, "%s:%d: internal check failed: %s\n", file, line, expr);
    abort();
}
