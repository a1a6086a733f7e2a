/*
 * explore/json.h: the small JSON reader and writer of the explorer's API (explore.h).
 *
 * Reader: a whole document parsed into a node array the caller owns (spc_json_doc); strings are
 * unescaped into the document's own buffer (\uXXXX beyond ASCII is refused: the API's strings are
 * names). Limits: SPC_JSON_MAX_DEPTH nesting, numbers as strtod reads them, finite only.
 * Writer: a growing buffer; non-finite numbers are written as null.
 */
#ifndef SPC_EXPLORE_JSON_H
#define SPC_EXPLORE_JSON_H

#include <stdbool.h>
#include <stddef.h>

#define SPC_JSON_MAX_DEPTH 16

typedef enum spc_json_type {
    SPC_JSON_NULL,
    SPC_JSON_BOOL,
    SPC_JSON_NUMBER,
    SPC_JSON_STRING,
    SPC_JSON_ARRAY,
    SPC_JSON_OBJECT
} spc_json_type;

typedef struct spc_json {
    spc_json_type type;
    double num;      /* NUMBER; BOOL: 0 or 1 */
    const char *str; /* STRING: NUL-terminated, in the document */
    const char *key; /* member of an OBJECT: its name; NULL otherwise */
    int child;       /* ARRAY, OBJECT: index of the first element, -1 if empty */
    int next;        /* next sibling, -1 for the last */
    int count;       /* ARRAY, OBJECT: elements */
} spc_json;

typedef struct spc_json_doc {
    spc_json *nodes; /* nodes[0] is the root */
    int n;
    char *strings;
} spc_json_doc;

/* Parses len bytes. SPC_JSON ok: true; otherwise false with a message naming the byte offset in
 * msg. The document is freed with spc_json_doc_release (also after a failure). */
bool spc_json_parse(const char *text, size_t len, spc_json_doc *doc, char *msg, size_t msg_size);
void spc_json_doc_release(spc_json_doc *doc);
/* The member `key` of object node i, or NULL (i not an object, or no such member). */
const spc_json *spc_json_get(const spc_json_doc *doc, const spc_json *obj, const char *key);
/* Element k of an array, or NULL. */
const spc_json *spc_json_at(const spc_json_doc *doc, const spc_json *arr, int k);

/* ---- writer ---- */
typedef struct spc_jbuf {
    char *s; /* NUL-terminated; the caller takes it (free) */
    size_t n, cap;
    bool failed; /* an allocation failed: the text is incomplete */
} spc_jbuf;

void spc_jbuf_raw(spc_jbuf *b, const char *s);
void spc_jbuf_printf(spc_jbuf *b, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
void spc_jbuf_num(spc_jbuf *b, double v);
void spc_jbuf_str(spc_jbuf *b, const char *s);
/* "[a,b,c]" */
void spc_jbuf_vec(spc_jbuf *b, const double *v, int n);

#endif
