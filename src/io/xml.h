/*
 * io/xml.h: a small XML document tree built with expat, for the scene loader.
 *
 * Each element keeps its name, its attributes in document order, its child elements, and where it
 * starts: the file name it was read from, its line and its 1-based column (of the '<'). Text
 * between elements is ignored when it is only white space; other text is a syntax error, as are
 * all of expat's errors, reported as "file:line:col: message" with SPC_ERR_PARSE.
 *
 * Ownership: spc_xml_parse returns a tree the caller frees with spc_xml_free. Nodes keep the
 * `file` pointer given to the parser without copying it: the caller keeps that string alive for as
 * long as the tree (or any node moved out of it) lives.
 */
#ifndef SPC_IO_XML_H
#define SPC_IO_XML_H

#include <stdbool.h>
#include <stddef.h>

#include "core/error.h"

typedef struct spc_xml_attr {
    char *name, *value;
} spc_xml_attr;

typedef struct spc_xml_node {
    char *name;
    spc_xml_attr *attrs;
    int nattrs;
    struct spc_xml_node **children;
    int nchildren, cap_children;
    struct spc_xml_node *parent;
    const char *file; /* not owned; see above */
    int line, col;    /* 1-based, of the element's '<' */
    int user;         /* free for the client; 0 after parsing */
} spc_xml_node;

/* Parses len bytes of text. On success *out is the root element. On failure *out is NULL and err
 * says where (SPC_ERR_PARSE) or that memory ran out (SPC_ERR_NOMEM). */
spc_status spc_xml_parse(const char *text, size_t len, const char *file, spc_xml_node **out, spc_error *err);
/* Reads a whole file into a NUL-terminated buffer the caller frees. SPC_ERR_IO names the path. */
spc_status spc_xml_read_file(const char *path, char **text, size_t *len, spc_error *err);
/* Frees a node, its attributes and all its descendants; NULL does nothing. */
void spc_xml_free(spc_xml_node *n);

/* The value of attribute `name`, or NULL. */
const char *spc_xml_get(const spc_xml_node *n, const char *name);
/* Sets (replacing or appending) an attribute; false on allocation failure. */
bool spc_xml_set(spc_xml_node *n, const char *name, const char *value);
/* Renames an element; false on allocation failure. */
bool spc_xml_rename(spc_xml_node *n, const char *name);
/* Replaces child i of parent by the children of `from` (in order), which is left without
 * children; returns false on allocation failure (the tree is then unchanged). The replaced child
 * is freed. */
bool spc_xml_splice(spc_xml_node *parent, int i, spc_xml_node *from);

#endif
