/*
 * io/xml.c: builds an element tree from XML text with expat (SAX callbacks push and pop a stack
 * of open elements). Positions come from XML_GetCurrentLineNumber/ColumnNumber at the start tag;
 * expat's columns are 0-based, ours 1-based. Non-blank text outside of markup is refused, like
 * Mitsuba's loader does, since no element of a scene file carries text.
 */
#include "io/xml.h"

#include <expat.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct builder {
    XML_Parser parser;
    const char *file;
    spc_xml_node *root;
    spc_xml_node *cur; /* innermost open element */
    bool nomem;
    bool text_error;
    int text_line, text_col;
} builder;

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

static bool add_child(spc_xml_node *parent, spc_xml_node *child)
{
    if (parent->nchildren == parent->cap_children) {
        int cap = parent->cap_children ? 2 * parent->cap_children : 4;
        spc_xml_node **c = realloc(parent->children, (size_t)cap * sizeof *c);
        if (!c)
            return false;
        parent->children = c;
        parent->cap_children = cap;
    }
    parent->children[parent->nchildren++] = child;
    child->parent = parent;
    return true;
}

static void XMLCALL on_start(void *user, const XML_Char *name, const XML_Char **atts)
{
    builder *b = user;
    if (b->nomem || b->text_error)
        return;
    spc_xml_node *n = calloc(1, sizeof *n);
    if (!n)
        goto oom;
    n->file = b->file;
    n->line = (int)XML_GetCurrentLineNumber(b->parser);
    n->col = (int)XML_GetCurrentColumnNumber(b->parser) + 1;
    n->name = dup_str(name);
    if (!n->name)
        goto oom_node;
    int na = 0;
    while (atts[2 * na])
        ++na;
    if (na > 0) {
        n->attrs = calloc((size_t)na, sizeof *n->attrs);
        if (!n->attrs)
            goto oom_node;
        for (int i = 0; i < na; ++i) {
            n->attrs[i].name = dup_str(atts[2 * i]);
            n->attrs[i].value = dup_str(atts[2 * i + 1]);
            n->nattrs = i + 1;
            if (!n->attrs[i].name || !n->attrs[i].value)
                goto oom_node;
        }
    }
    if (b->cur) {
        if (!add_child(b->cur, n))
            goto oom_node;
    } else {
        b->root = n;
    }
    b->cur = n;
    return;
oom_node:
    spc_xml_free(n);
oom:
    b->nomem = true;
    XML_StopParser(b->parser, XML_FALSE);
}

static void XMLCALL on_end(void *user, const XML_Char *name)
{
    (void)name;
    builder *b = user;
    if (b->nomem || b->text_error || !b->cur)
        return;
    b->cur = b->cur->parent;
}

static void XMLCALL on_text(void *user, const XML_Char *s, int len)
{
    builder *b = user;
    if (b->nomem || b->text_error)
        return;
    /* the position of the chunk's start, advanced to its first non-blank character */
    int line = (int)XML_GetCurrentLineNumber(b->parser);
    int col = (int)XML_GetCurrentColumnNumber(b->parser) + 1;
    for (int i = 0; i < len; ++i) {
        char c = s[i];
        if (c == '\n') {
            ++line;
            col = 1;
        } else if (c == ' ' || c == '\t' || c == '\r') {
            ++col;
        } else {
            b->text_error = true;
            b->text_line = line;
            b->text_col = col;
            XML_StopParser(b->parser, XML_FALSE);
            return;
        }
    }
}

spc_status spc_xml_parse(const char *text, size_t len, const char *file, spc_xml_node **out, spc_error *err)
{
    *out = NULL;
    builder b = {0};
    b.file = file;
    b.parser = XML_ParserCreate(NULL);
    if (!b.parser)
        return spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory creating the XML parser");
    XML_SetUserData(b.parser, &b);
    XML_SetElementHandler(b.parser, on_start, on_end);
    XML_SetCharacterDataHandler(b.parser, on_text);

    spc_status st = SPC_OK;
    size_t done = 0;
    for (;;) {
        size_t chunk = len - done;
        if (chunk > (size_t)(INT_MAX / 2))
            chunk = (size_t)(INT_MAX / 2);
        int final = done + chunk == len;
        enum XML_Status xs = XML_Parse(b.parser, text + done, (int)chunk, final);
        done += chunk;
        if (b.nomem) {
            st = spc_error_set(err, SPC_ERR_NOMEM, file, 0, 0, "out of memory while parsing XML");
            break;
        }
        if (b.text_error) {
            st = spc_error_set(err, SPC_ERR_PARSE, file, b.text_line, b.text_col,
                               "unexpected text content (scene elements carry no text)");
            break;
        }
        if (xs != XML_STATUS_OK) {
            st = spc_error_set(err, SPC_ERR_PARSE, file, (int)XML_GetCurrentLineNumber(b.parser),
                               (int)XML_GetCurrentColumnNumber(b.parser) + 1, "malformed XML: %s",
                               XML_ErrorString(XML_GetErrorCode(b.parser)));
            break;
        }
        if (final)
            break;
    }
    XML_ParserFree(b.parser);
    if (st == SPC_OK && !b.root)
        st = spc_error_set(err, SPC_ERR_PARSE, file, 1, 1, "malformed XML: no element");
    if (st != SPC_OK) {
        spc_xml_free(b.root);
        return st;
    }
    *out = b.root;
    return SPC_OK;
}

spc_status spc_xml_read_file(const char *path, char **text, size_t *len, spc_error *err)
{
    *text = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot open file");
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading file");
    }
    for (;;) {
        if (n + 1 >= cap) {
            char *nb = realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                fclose(f);
                return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory reading file");
            }
            buf = nb;
            cap *= 2;
        }
        size_t r = fread(buf + n, 1, cap - 1 - n, f);
        n += r;
        if (r == 0)
            break;
    }
    bool bad = ferror(f) != 0;
    fclose(f);
    if (bad) {
        free(buf);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "read error");
    }
    buf[n] = '\0';
    *text = buf;
    *len = n;
    return SPC_OK;
}

void spc_xml_free(spc_xml_node *n)
{
    if (!n)
        return;
    for (int i = 0; i < n->nchildren; ++i)
        spc_xml_free(n->children[i]);
    free(n->children);
    for (int i = 0; i < n->nattrs; ++i) {
        free(n->attrs[i].name);
        free(n->attrs[i].value);
    }
    free(n->attrs);
    free(n->name);
    free(n);
}

const char *spc_xml_get(const spc_xml_node *n, const char *name)
{
    for (int i = 0; i < n->nattrs; ++i)
        if (strcmp(n->attrs[i].name, name) == 0)
            return n->attrs[i].value;
    return NULL;
}

bool spc_xml_set(spc_xml_node *n, const char *name, const char *value)
{
    char *v = dup_str(value);
    if (!v)
        return false;
    for (int i = 0; i < n->nattrs; ++i) {
        if (strcmp(n->attrs[i].name, name) == 0) {
            free(n->attrs[i].value);
            n->attrs[i].value = v;
            return true;
        }
    }
    char *k = dup_str(name);
    spc_xml_attr *a = realloc(n->attrs, (size_t)(n->nattrs + 1) * sizeof *a);
    if (!k || !a) {
        free(k);
        free(v);
        if (a)
            n->attrs = a;
        return false;
    }
    n->attrs = a;
    n->attrs[n->nattrs].name = k;
    n->attrs[n->nattrs].value = v;
    ++n->nattrs;
    return true;
}

bool spc_xml_rename(spc_xml_node *n, const char *name)
{
    char *s = dup_str(name);
    if (!s)
        return false;
    free(n->name);
    n->name = s;
    return true;
}

bool spc_xml_splice(spc_xml_node *parent, int i, spc_xml_node *from)
{
    int k = from->nchildren;
    int total = parent->nchildren - 1 + k;
    if (total > parent->cap_children) {
        spc_xml_node **c = realloc(parent->children, (size_t)total * sizeof *c);
        if (!c)
            return false;
        parent->children = c;
        parent->cap_children = total;
    }
    spc_xml_node *old = parent->children[i];
    memmove(parent->children + i + k, parent->children + i + 1,
            (size_t)(parent->nchildren - i - 1) * sizeof *parent->children);
    for (int j = 0; j < k; ++j) {
        parent->children[i + j] = from->children[j];
        from->children[j]->parent = parent;
    }
    parent->nchildren = total;
    from->nchildren = 0;
    spc_xml_free(old);
    return true;
}
