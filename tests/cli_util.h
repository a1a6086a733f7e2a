/*
 * tests/cli_util.h: running the `specula` command from a test, once for every test that does.
 *
 * cli_init finds the binary ($SPC_BINARY_DIR/specula under ctest, else beside the test program) and
 * makes a temporary directory; run, run_v and spawn_v start the command in that directory with
 * stdout to out.txt and stderr to err.txt there; run and run_v return its exit status (128 + signal
 * if killed, -1 if it could not run). Names given to the helpers are relative to the temporary
 * directory. The helpers are static, one copy per test program, like the harness's.
 */
#ifndef SPC_TESTS_CLI_UTIL_H
#define SPC_TESTS_CLI_UTIL_H

#include <fcntl.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

/* The exit status of a bad command line (tools/specula.c); failures exit with their spc_status. */
#define EXIT_USAGE 64

static char tmpdir[64];
static char binary[2048];

/* Finds the binary and makes /tmp/spc_<name>_XXXXXX; false (and why printed) if either fails. */
static inline bool cli_init(const char *name)
{
    const char *bin = getenv("SPC_BINARY_DIR");
    char self[900];
    ssize_t n = bin ? -1 : readlink("/proc/self/exe", self, sizeof self - 1);
    if (n > 0) {
        self[n] = '\0';
        char *slash = strrchr(self, '/');
        if (slash)
            *slash = '\0';
        bin = self;
    }
    snprintf(binary, sizeof binary, "%s/specula", bin ? bin : "build");
    if (binary[0] != '/') { /* the child changes directory */
        char cwd[512], rel[1000];
        if (getcwd(cwd, sizeof cwd)) {
            snprintf(rel, sizeof rel, "%.999s", binary);
            snprintf(binary, sizeof binary, "%s/%s", cwd, rel);
        }
    }
    if (access(binary, X_OK) != 0) {
        printf("cannot run %s (set SPC_BINARY_DIR)\n", binary);
        return false;
    }
    snprintf(tmpdir, sizeof tmpdir, "/tmp/spc_%.20s_XXXXXX", name);
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return false;
    }
    return true;
}

/* After spc_test_finish's rc: removes the temporary directory if every test passed, else says where
 * its files are kept. Returns rc. */
static inline int cli_finish(int rc)
{
    if (rc == 0) {
        char cmd[600];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
        if (system(cmd) != 0)
            printf("could not remove %s\n", tmpdir);
    } else {
        printf("files kept in %s\n", tmpdir);
    }
    return rc;
}

/* name inside the temporary directory (eight buffers in rotation). */
static inline const char *tmp_path(const char *name)
{
    static char buf[8][600];
    static int k = 0;
    k = (k + 1) % 8;
    snprintf(buf[k], sizeof buf[k], "%s/%s", tmpdir, name);
    return buf[k];
}

static inline bool write_file(const char *name, const char *text)
{
    FILE *fp = fopen(tmp_path(name), "wb");
    if (!fp)
        return false;
    bool ok = fputs(text, fp) >= 0;
    return fclose(fp) == 0 && ok;
}

/* The whole file, terminated (caller frees), its size in *size unless NULL; NULL if unreadable. */
static inline unsigned char *read_bytes(const char *name, size_t *size)
{
    FILE *fp = fopen(tmp_path(name), "rb");
    if (!fp)
        return NULL;
    size_t cap = 4096, len = 0;
    unsigned char *buf = malloc(cap);
    for (size_t n; buf && (n = fread(buf + len, 1, cap - len - 1, fp)) > 0;) {
        len += n;
        if (cap - len < 2) {
            unsigned char *nb = realloc(buf, cap *= 2);
            if (!nb)
                free(buf);
            buf = nb;
        }
    }
    fclose(fp);
    if (buf)
        buf[len] = '\0';
    if (size)
        *size = len;
    return buf;
}

static inline char *read_text(const char *name) { return (char *)read_bytes(name, NULL); }

static inline bool exists(const char *name) { return access(tmp_path(name), F_OK) == 0; }

/* Starts `specula ARGS` (a NULL-terminated array) in the temporary directory; the environment
 * variable env_name is set to env_value first (unset if env_value is NULL) unless env_name is NULL.
 * Returns the child's pid, or -1. */
static inline pid_t spawn_env(const char *env_name, const char *env_value, const char *const *args)
{
    const char *argv[64];
    int n = 0;
    argv[n++] = binary;
    for (int i = 0; args[i] && n < 63; ++i)
        argv[n++] = args[i];
    argv[n] = NULL;
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        if (chdir(tmpdir) != 0)
            _exit(126);
        int fo = open("out.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int fe = open("err.txt", O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fo < 0 || fe < 0 || dup2(fo, 1) < 0 || dup2(fe, 2) < 0)
            _exit(126);
        close(fo);
        close(fe);
        if (env_name && env_value)
            setenv(env_name, env_value, 1);
        else if (env_name)
            unsetenv(env_name);
        execv(binary, (char *const *)argv);
        _exit(127);
    }
    return pid;
}

static inline pid_t spawn_v(const char *const *args) { return spawn_env(NULL, NULL, args); }

/* The exit status of a child, 128 + signal if killed, -1 on error. */
static inline int wait_code(pid_t pid)
{
    int st = 0;
    if (pid < 0 || waitpid(pid, &st, 0) != pid)
        return -1;
    if (WIFEXITED(st))
        return WEXITSTATUS(st);
    return WIFSIGNALED(st) ? 128 + WTERMSIG(st) : -1;
}

/* Runs `specula ARGS` (a NULL-terminated array) and waits. */
static inline int run_v(const char *const *args) { return wait_code(spawn_v(args)); }

/* Runs `specula ARG0 ...` (NULL-terminated arguments) and waits. */
static inline int run(const char *arg0, ...)
{
    const char *args[64];
    int n = 0;
    va_list ap;
    va_start(ap, arg0);
    for (const char *a = arg0; a && n < 63; a = va_arg(ap, const char *))
        args[n++] = a;
    va_end(ap);
    args[n] = NULL;
    return run_v(args);
}

/* Does the last run's file (out.txt, err.txt) contain needle? Prints the file if not. */
static inline bool file_has(const char *file, const char *needle)
{
    char *e = read_text(file);
    bool found = e && strstr(e, needle);
    if (!found)
        printf("  %s lacks \"%s\": %s\n", file, needle, e ? e : "(none)");
    free(e);
    return found;
}

static inline bool err_has(const char *needle) { return file_has("err.txt", needle); }
static inline bool out_has(const char *needle) { return file_has("out.txt", needle); }

/* Prints what the last run said, to diagnose a failed check. */
static inline void show_output(void)
{
    char *o = read_text("out.txt"), *e = read_text("err.txt");
    printf("  --- stdout:\n%s  --- stderr:\n%s  ---\n", o ? o : "(none)\n", e ? e : "(none)\n");
    free(o);
    free(e);
}

#endif
