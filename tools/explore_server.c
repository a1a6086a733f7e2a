/*
 * tools/explore_server.c: the HTTP side of `specula explore` (libmicrohttpd), kept thin: it binds
 * 127.0.0.1 only, serves the page and its scripts from a fixed table (the page embedded at build
 * time from tools/explore/, three.js read once at start from Debian's libjs-three), hands /api/
 * requests to spc_explore_handle (the library's handlers, specula.h), and stops on SIGINT/SIGTERM.
 * No part of a request's path reaches the file system: a path is looked up in the table or passed
 * to the API, which knows three names. Requests whose Host header is not this address are refused
 * (403), which keeps pages of other sites out through DNS rebinding. Bodies over SPC_EXPLORE_MAX_BODY are refused (413) without
 * being kept.
 */
#include "explore_server.h"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "specula/specula.h"

#define DEFAULT_PORT 8765
/* Where Debian's libjs-three installs the browser build of three.js. */
#define THREE_JS_PATH "/usr/share/javascript/three/three.min.js"
/* Connections at once: one page makes two or three. */
#define MAX_CONNECTIONS 16
/* Seconds an idle connection is kept. */
#define CONNECTION_TIMEOUT 30

extern const unsigned char spc_explore_index_html[];
extern const unsigned long spc_explore_index_html_size;
extern const unsigned char spc_explore_page_js[];
extern const unsigned long spc_explore_page_js_size;

static const char *const usage_explore =
    "usage: specula explore SCENE.xml [--port N] [-D name=value ...]\n"
    "  Serves the solver explorer on http://127.0.0.1:N/ (default 8765; 0 picks a free port): the\n"
    "  scene in 3D, a receiver point to click and drag, every solver's iterations, gradients,\n"
    "  solutions and the loss map, and a 2D slice playground. Ctrl-C stops it.\n";

typedef struct asset {
    const char *url, *type;
    const unsigned char *data;
    size_t size;
} asset;

typedef struct server {
    spc_explorer *ex;
    asset assets[3];
    char host_ip[32], host_name[32]; /* the Host headers accepted: 127.0.0.1:PORT, localhost:PORT */
} server;

/* The body of one request, gathered across calls. */
typedef struct body {
    char *data;
    size_t n;
    bool too_large;
} body;

static volatile sig_atomic_t stop_requested = 0;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

static enum MHD_Result send_text(struct MHD_Connection *c, unsigned status, const char *type, const void *data,
                                 size_t size, enum MHD_ResponseMemoryMode mode)
{
    struct MHD_Response *r = MHD_create_response_from_buffer(size, (void *)data, mode);
    if (!r)
        return MHD_NO;
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    MHD_add_response_header(r, "X-Content-Type-Options", "nosniff");
    enum MHD_Result ret = MHD_queue_response(c, status, r);
    MHD_destroy_response(r);
    return ret;
}

static enum MHD_Result send_json(struct MHD_Connection *c, unsigned status, char *json)
{
    if (!json) {
        static const char oom[] = "{\"error\":\"out of memory\"}";
        return send_text(c, 500, "application/json", oom, sizeof oom - 1, MHD_RESPMEM_PERSISTENT);
    }
    return send_text(c, status, "application/json", json, strlen(json), MHD_RESPMEM_MUST_FREE);
}

static enum MHD_Result answer(void *cls, struct MHD_Connection *c, const char *url, const char *method,
                              const char *version, const char *upload, size_t *upload_size, void **con_cls)
{
    (void)version;
    server *sv = cls;
    body *b = *con_cls;
    if (!b) {
        b = calloc(1, sizeof *b);
        if (!b)
            return MHD_NO;
        *con_cls = b;
        const char *len = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_CONTENT_LENGTH);
        if (len && strtoull(len, NULL, 10) > SPC_EXPLORE_MAX_BODY)
            b->too_large = true;
        return MHD_YES;
    }
    if (*upload_size) {
        if (!b->too_large) {
            if (b->n + *upload_size > SPC_EXPLORE_MAX_BODY) {
                b->too_large = true;
            } else {
                char *d = realloc(b->data, b->n + *upload_size + 1);
                if (!d)
                    return MHD_NO;
                memcpy(d + b->n, upload, *upload_size);
                b->data = d;
                b->n += *upload_size;
                b->data[b->n] = '\0';
            }
        }
        *upload_size = 0;
        return MHD_YES;
    }
    /* only requests addressed to this server by name: a page elsewhere that rebinds its own DNS
     * name to 127.0.0.1 sends its own Host and is refused */
    const char *host = MHD_lookup_connection_value(c, MHD_HEADER_KIND, MHD_HTTP_HEADER_HOST);
    if (!host || (strcmp(host, sv->host_ip) != 0 && strcmp(host, sv->host_name) != 0)) {
        static const char msg[] = "{\"error\":\"unexpected Host header\"}";
        return send_text(c, 403, "application/json", msg, sizeof msg - 1, MHD_RESPMEM_PERSISTENT);
    }
    if (b->too_large) {
        char *msg = strdup("{\"error\":\"request body too large\"}");
        return send_json(c, 413, msg);
    }
    if (!strncmp(url, "/api/", 5)) {
        char *resp = NULL;
        int st = spc_explore_handle(sv->ex, method, url, b->data, b->n, &resp);
        return send_json(c, (unsigned)st, resp);
    }
    if (strcmp(method, "GET") != 0 && strcmp(method, "HEAD") != 0) {
        static const char msg[] = "method not allowed\n";
        return send_text(c, 405, "text/plain", msg, sizeof msg - 1, MHD_RESPMEM_PERSISTENT);
    }
    for (int i = 0; i < 3; ++i)
        if (!strcmp(url, sv->assets[i].url))
            return send_text(c, 200, sv->assets[i].type, sv->assets[i].data, sv->assets[i].size,
                             MHD_RESPMEM_PERSISTENT);
    static const char nf[] = "not found\n";
    return send_text(c, 404, "text/plain", nf, sizeof nf - 1, MHD_RESPMEM_PERSISTENT);
}

static void completed(void *cls, struct MHD_Connection *c, void **con_cls, enum MHD_RequestTerminationCode toe)
{
    (void)cls;
    (void)c;
    (void)toe;
    body *b = *con_cls;
    if (b) {
        free(b->data);
        free(b);
        *con_cls = NULL;
    }
}

/* Reads a whole file (three.js); NULL with a message on failure. */
static unsigned char *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    unsigned char *d = NULL;
    size_t cap = 0, n = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? 2 * cap : 1 << 20;
            unsigned char *nd = realloc(d, cap);
            if (!nd) {
                free(d);
                fclose(f);
                return NULL;
            }
            d = nd;
        }
        size_t k = fread(d + n, 1, cap - n, f);
        n += k;
        if (k == 0)
            break;
    }
    bool err = ferror(f);
    fclose(f);
    if (err) {
        free(d);
        return NULL;
    }
    *size = n;
    return d;
}

int spc_cli_explore(int argc, char **argv)
{
    const char *scene_path = NULL;
    long port = DEFAULT_PORT;
    spc_define defs[64];
    int ndefs = 0;
    for (int i = 0; i < argc; ++i) {
        const char *a = argv[i];
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            fputs(usage_explore, stdout);
            return 0;
        } else if (!strcmp(a, "--port")) {
            char *end = NULL;
            port = i + 1 < argc ? strtol(argv[i + 1], &end, 10) : -1;
            if (i + 1 >= argc || !end || *end || port < 0 || port > 65535) {
                fprintf(stderr, "specula: --port needs a number from 0 to 65535\n%s", usage_explore);
                return 2;
            }
            ++i;
        } else if (!strcmp(a, "-D")) {
            char *eq = i + 1 < argc ? strchr(argv[i + 1], '=') : NULL;
            if (!eq || ndefs == 64) {
                fprintf(stderr, "specula: -D needs name=value\n%s", usage_explore);
                return 2;
            }
            *eq = '\0';
            defs[ndefs].name = argv[i + 1];
            defs[ndefs].value = eq + 1;
            ++ndefs;
            ++i;
        } else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "specula: unknown option '%s'\n%s", a, usage_explore);
            return 2;
        } else if (scene_path) {
            fprintf(stderr, "specula: more than one scene given ('%s' and '%s')\n%s", scene_path, a, usage_explore);
            return 2;
        } else {
            scene_path = a;
        }
    }
    if (!scene_path) {
        fprintf(stderr, "specula: no scene given\n%s", usage_explore);
        return 2;
    }
    size_t three_size = 0;
    unsigned char *three = read_file(THREE_JS_PATH, &three_size);
    if (!three) {
        fprintf(stderr, "specula: %s: cannot read three.js (install Debian's libjs-three)\n", THREE_JS_PATH);
        return 3;
    }
    spc_scene *scene = NULL;
    spc_error err;
    memset(&err, 0, sizeof err);
    if (spc_scene_load(scene_path, defs, ndefs, &scene, &err) != SPC_OK) {
        char buf[SPC_ERROR_MSG_MAX + 600];
        spc_error_format(&err, buf, (int)sizeof buf);
        fprintf(stderr, "specula: %s\n", buf);
        free(three);
        return 3;
    }
    server sv;
    sv.ex = spc_explore_create(scene);
    sv.assets[0] = (asset){"/", "text/html; charset=utf-8", spc_explore_index_html, spc_explore_index_html_size};
    sv.assets[1] = (asset){"/explore.js", "text/javascript", spc_explore_page_js, spc_explore_page_js_size};
    sv.assets[2] = (asset){"/three.min.js", "text/javascript", three, three_size};
    struct sockaddr_in addr;
    memset(&addr, 0, sizeof addr);
    addr.sin_family = AF_INET;
    addr.sin_port = htons((uint16_t)port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    struct MHD_Daemon *d =
        sv.ex ? MHD_start_daemon(MHD_USE_AUTO_INTERNAL_THREAD | MHD_USE_ERROR_LOG, (uint16_t)port, NULL, NULL, answer,
                                 &sv, MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&addr, MHD_OPTION_CONNECTION_LIMIT,
                                 (unsigned)MAX_CONNECTIONS, MHD_OPTION_CONNECTION_TIMEOUT, (unsigned)CONNECTION_TIMEOUT,
                                 MHD_OPTION_NOTIFY_COMPLETED, completed, NULL, MHD_OPTION_END)
              : NULL;
    if (!d) {
        fprintf(stderr, "specula: cannot listen on 127.0.0.1:%ld (port in use?)\n", port);
        spc_explore_destroy(sv.ex);
        spc_scene_destroy(scene);
        free(three);
        return 4;
    }
    const union MHD_DaemonInfo *info = MHD_get_daemon_info(d, MHD_DAEMON_INFO_BIND_PORT);
    unsigned bound = info ? info->port : (unsigned)port;
    /* browsers leave the default port out of Host */
    if (bound == 80) {
        snprintf(sv.host_ip, sizeof sv.host_ip, "127.0.0.1");
        snprintf(sv.host_name, sizeof sv.host_name, "localhost");
    } else {
        snprintf(sv.host_ip, sizeof sv.host_ip, "127.0.0.1:%u", bound);
        snprintf(sv.host_name, sizeof sv.host_name, "localhost:%u", bound);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    printf("specula explore: %s on http://127.0.0.1:%u/ (Ctrl-C stops)\n", scene_path, bound);
    fflush(stdout);
    while (!stop_requested) {
        struct timespec ts = {0, 100 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    MHD_stop_daemon(d);
    spc_explore_destroy(sv.ex);
    spc_scene_destroy(scene);
    free(three);
    printf("specula explore: stopped\n");
    return 0;
}
