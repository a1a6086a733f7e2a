/*
 * explore/json.c: a recursive-descent JSON reader (RFC 8259, with the limits explore/json.h
 * states) into a flat node array, and a growing-buffer writer. Small on purpose: the explorer's
 * requests are a few kilobytes (explore.h), its responses a few hundred.
 */
#include "explore/json.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct parser {
    const char *s, *end, *start;
    spc_json_doc *doc;
    int cap;
    char *out; /* next free byte of doc->strings */
    char *msg;
    size_t msg_size;
} parser;

static bool fail(parser *p, const char *what)
{
    if (p->msg && p->msg_size)
        snprintf(p->msg, p->msg_size, "malformed JSON at byte %d: %s", (int)(p->s - p->start), what);
    return false;
}

static void skip_ws(parser *p)
{
    while (p->s < p->end && (*p->s == ' ' || *p->s == '\t' || *p->s == '\n' || *p->s == '\r'))
        ++p->s;
}

static int new_node(parser *p, spc_json_type t)
{
    spc_json_doc *d = p->doc;
    if (d->n == p->cap) {
        int cap = p->cap ? 2 * p->cap : 32;
        spc_json *nn = realloc(d->nodes, (size_t)cap * sizeof *nn);
        if (!nn)
            return -1;
        d->nodes = nn;
        p->cap = cap;
    }
    spc_json *j = &d->nodes[d->n];
    memset(j, 0, sizeof *j);
    j->type = t;
    j->child = -1;
    j->next = -1;
    return d->n++;
}

static int hexval(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/* At the opening quote; writes the unescaped string to p->out and returns its start. */
static const char *parse_string(parser *p)
{
    ++p->s;
    char *o = p->out, *start = o;
    while (p->s < p->end && *p->s != '"') {
        unsigned char c = (unsigned char)*p->s++;
        if (c < 0x20) {
            fail(p, "control character in a string");
            return NULL;
        }
        if (c != '\\') {
            *o++ = (char)c;
            continue;
        }
        if (p->s >= p->end)
            break;
        char e = *p->s++;
        switch (e) {
        case '"':
            *o++ = '"';
            break;
        case '\\':
            *o++ = '\\';
            break;
        case '/':
            *o++ = '/';
            break;
        case 'b':
            *o++ = '\b';
            break;
        case 'f':
            *o++ = '\f';
            break;
        case 'n':
            *o++ = '\n';
            break;
        case 'r':
            *o++ = '\r';
            break;
        case 't':
            *o++ = '\t';
            break;
        case 'u': {
            int v = 0;
            for (int k = 0; k < 4; ++k) {
                int h = p->s < p->end ? hexval(*p->s++) : -1;
                if (h < 0) {
                    fail(p, "bad \\u escape");
                    return NULL;
                }
                v = v * 16 + h;
            }
            if (v < 1 || v > 0x7f) {
                fail(p, "\\u escape beyond ASCII");
                return NULL;
            }
            *o++ = (char)v;
            break;
        }
        default:
            fail(p, "bad escape");
            return NULL;
        }
    }
    if (p->s >= p->end) {
        fail(p, "unterminated string");
        return NULL;
    }
    ++p->s;
    *o++ = '\0';
    p->out = o;
    return start;
}

static bool literal(parser *p, const char *word)
{
    size_t n = strlen(word);
    if ((size_t)(p->end - p->s) < n || memcmp(p->s, word, n) != 0)
        return false;
    p->s += n;
    return true;
}

static int parse_value(parser *p, int depth);

static int parse_container(parser *p, int depth, bool object)
{
    int self = new_node(p, object ? SPC_JSON_OBJECT : SPC_JSON_ARRAY);
    if (self < 0)
        return fail(p, "out of memory"), -1;
    ++p->s;
    skip_ws(p);
    char close = object ? '}' : ']';
    if (p->s < p->end && *p->s == close) {
        ++p->s;
        return self;
    }
    int last = -1;
    for (;;) {
        skip_ws(p);
        const char *key = NULL;
        if (object) {
            if (p->s >= p->end || *p->s != '"')
                return fail(p, "expected a member name"), -1;
            if (!(key = parse_string(p)))
                return -1;
            skip_ws(p);
            if (p->s >= p->end || *p->s != ':')
                return fail(p, "expected ':'"), -1;
            ++p->s;
        }
        int v = parse_value(p, depth + 1);
        if (v < 0)
            return -1;
        p->doc->nodes[v].key = key;
        if (last < 0)
            p->doc->nodes[self].child = v;
        else
            p->doc->nodes[last].next = v;
        last = v;
        p->doc->nodes[self].count++;
        skip_ws(p);
        if (p->s < p->end && *p->s == ',') {
            ++p->s;
            continue;
        }
        if (p->s < p->end && *p->s == close) {
            ++p->s;
            return self;
        }
        return fail(p, object ? "expected ',' or '}'" : "expected ',' or ']'"), -1;
    }
}

static int parse_value(parser *p, int depth)
{
    if (depth > SPC_JSON_MAX_DEPTH)
        return fail(p, "nested too deeply"), -1;
    skip_ws(p);
    if (p->s >= p->end)
        return fail(p, "unexpected end"), -1;
    char c = *p->s;
    if (c == '{' || c == '[')
        return parse_container(p, depth, c == '{');
    if (c == '"') {
        int i = new_node(p, SPC_JSON_STRING);
        if (i < 0)
            return fail(p, "out of memory"), -1;
        const char *s = parse_string(p);
        if (!s)
            return -1;
        p->doc->nodes[i].str = s;
        return i;
    }
    if (literal(p, "true") || literal(p, "false") || literal(p, "null")) {
        bool isnull = p->s[-1] == 'l';
        int i = new_node(p, isnull ? SPC_JSON_NULL : SPC_JSON_BOOL);
        if (i < 0)
            return fail(p, "out of memory"), -1;
        p->doc->nodes[i].num = p->s[-1] == 'e' && p->s[-2] == 'u' ? 1.0 : 0.0;
        return i;
    }
    if (c == '-' || (c >= '0' && c <= '9')) {
        /* the JSON number grammar, then strtod on a bounded copy */
        const char *q = p->s;
        if (q < p->end && *q == '-')
            ++q;
        const char *digits = q;
        while (q < p->end && *q >= '0' && *q <= '9')
            ++q;
        if (q == digits || (*digits == '0' && q - digits > 1))
            return fail(p, "bad number"), -1;
        if (q < p->end && *q == '.') {
            const char *f = ++q;
            while (q < p->end && *q >= '0' && *q <= '9')
                ++q;
            if (q == f)
                return fail(p, "bad number"), -1;
        }
        if (q < p->end && (*q == 'e' || *q == 'E')) {
            ++q;
            if (q < p->end && (*q == '+' || *q == '-'))
                ++q;
            const char *e = q;
            while (q < p->end && *q >= '0' && *q <= '9')
                ++q;
            if (q == e)
                return fail(p, "bad number"), -1;
        }
        char buf[64];
        size_t n = (size_t)(q - p->s);
        if (n >= sizeof buf)
            return fail(p, "number too long"), -1;
        memcpy(buf, p->s, n);
        buf[n] = '\0';
        double v = strtod(buf, NULL);
        if (!isfinite(v))
            return fail(p, "number out of range"), -1;
        int i = new_node(p, SPC_JSON_NUMBER);
        if (i < 0)
            return fail(p, "out of memory"), -1;
        p->doc->nodes[i].num = v;
        p->s = q;
        return i;
    }
    return fail(p, "unexpected character"), -1;
}

bool spc_json_parse(const char *text, size_t len, spc_json_doc *doc, char *msg, size_t msg_size)
{
    memset(doc, 0, sizeof *doc);
    parser p = {text, text + len, text, doc, 0, NULL, msg, msg_size};
    doc->strings = malloc(len + 1);
    if (!doc->strings)
        return fail(&p, "out of memory");
    p.out = doc->strings;
    if (parse_value(&p, 0) < 0)
        return false;
    skip_ws(&p);
    if (p.s != p.end)
        return fail(&p, "trailing characters");
    return true;
}

void spc_json_doc_release(spc_json_doc *doc)
{
    free(doc->nodes);
    free(doc->strings);
    memset(doc, 0, sizeof *doc);
}

const spc_json *spc_json_get(const spc_json_doc *doc, const spc_json *obj, const char *key)
{
    if (!obj || obj->type != SPC_JSON_OBJECT)
        return NULL;
    for (int i = obj->child; i >= 0; i = doc->nodes[i].next)
        if (!strcmp(doc->nodes[i].key, key))
            return &doc->nodes[i];
    return NULL;
}

const spc_json *spc_json_at(const spc_json_doc *doc, const spc_json *arr, int k)
{
    if (!arr || arr->type != SPC_JSON_ARRAY || k < 0)
        return NULL;
    int i = arr->child;
    while (i >= 0 && k-- > 0)
        i = doc->nodes[i].next;
    return i >= 0 ? &doc->nodes[i] : NULL;
}

/* ---- writer ---- */

static bool reserve(spc_jbuf *b, size_t extra)
{
    if (b->failed)
        return false;
    if (b->n + extra + 1 <= b->cap)
        return true;
    size_t cap = b->cap ? b->cap : 4096;
    while (cap < b->n + extra + 1)
        cap *= 2;
    char *s = realloc(b->s, cap);
    if (!s) {
        b->failed = true;
        return false;
    }
    b->s = s;
    b->cap = cap;
    return true;
}

void spc_jbuf_raw(spc_jbuf *b, const char *s)
{
    size_t n = strlen(s);
    if (!reserve(b, n))
        return;
    memcpy(b->s + b->n, s, n + 1);
    b->n += n;
}

void spc_jbuf_printf(spc_jbuf *b, const char *fmt, ...)
{
    char tmp[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0)
        return;
    if ((size_t)n < sizeof tmp) {
        spc_jbuf_raw(b, tmp);
        return;
    }
    if (!reserve(b, (size_t)n))
        return;
    va_start(ap, fmt);
    vsnprintf(b->s + b->n, (size_t)n + 1, fmt, ap);
    va_end(ap);
    b->n += (size_t)n;
}

void spc_jbuf_num(spc_jbuf *b, double v)
{
    if (!isfinite(v))
        spc_jbuf_raw(b, "null");
    else
        spc_jbuf_printf(b, "%.17g", v);
}

void spc_jbuf_str(spc_jbuf *b, const char *s)
{
    spc_jbuf_raw(b, "\"");
    for (; *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            spc_jbuf_printf(b, "\\%c", c);
        else if (c < 0x20)
            spc_jbuf_printf(b, "\\u%04x", c);
        else {
            char t[2] = {(char)c, 0};
            spc_jbuf_raw(b, t);
        }
    }
    spc_jbuf_raw(b, "\"");
}

void spc_jbuf_vec(spc_jbuf *b, const double *v, int n)
{
    spc_jbuf_raw(b, "[");
    for (int i = 0; i < n; ++i) {
        if (i)
            spc_jbuf_raw(b, ",");
        spc_jbuf_num(b, v[i]);
    }
    spc_jbuf_raw(b, "]");
}
