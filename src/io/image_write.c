/*
 * io/image_write.c: what every image writer shares: the sRGB transfer functions, the atomic file
 * replacement, and the writer of the simple raster formats (pfm.c, hdr.c) over it. The format
 * writers (exr.c, png.c, ...) call it; it calls none of them.
 *
 * Atomic writes: the writer fills "<path>.tmp-<pid>", fsyncs it, renames it over path and fsyncs
 * the directory, so a crash or a failed write never leaves a truncated image under the final
 * name and never destroys the previous one (rename(2) is atomic on POSIX file systems). Only a
 * regular file is ever replaced: a symbolic link is followed to its target (written atomically in
 * the target's folder), and a directory, device, FIFO or socket is refused (spc_output_resolve).
 *
 * sRGB: IEC 61966-2-1, the piecewise curve with the linear toe below 0.04045 (encoded) /
 * 0.0031308 (linear).
 */
#include "io/image_io.h"

#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

double spc_srgb_to_linear(double v)
{
    if (v <= 0.04045)
        return v / 12.92;
    return pow((v + 0.055) / 1.055, 2.4);
}

double spc_linear_to_srgb(double v)
{
    if (v <= 0.0031308)
        return 12.92 * v;
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

/* ---- atomic writes ---- */

/* Follows symbolic links from path (relative targets are relative to the link's folder) to the
 * file that would be replaced, into out. False with err set when a link cannot be read, links
 * loop, or the name is too long. */
static bool follow_links(const char *path, char *out, size_t size, spc_error *err)
{
    if (snprintf(out, size, "%s", path) >= (int)size) {
        spc_error_set(err, SPC_ERR_IO, path, 0, 0, "path too long");
        return false;
    }
    for (int hops = 0; hops < SPC_OUTPUT_MAX_LINKS; ++hops) {
        struct stat st;
        if (lstat(out, &st) != 0 || !S_ISLNK(st.st_mode))
            return true;
        char target[4096];
        ssize_t n = readlink(out, target, sizeof target - 1);
        if (n < 0) {
            spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot read the symbolic link '%s': %s", out, strerror(errno));
            return false;
        }
        target[n] = '\0';
        char joined[4096];
        const char *slash = strrchr(out, '/');
        int len;
        if (target[0] == '/' || !slash)
            len = snprintf(joined, sizeof joined, "%s", target);
        else
            len = snprintf(joined, sizeof joined, "%.*s/%s", (int)(slash - out), out, target);
        if (len < 0 || (size_t)len >= sizeof joined || (size_t)len >= size) {
            spc_error_set(err, SPC_ERR_IO, path, 0, 0, "path too long after following symbolic links");
            return false;
        }
        memcpy(out, joined, (size_t)len + 1);
    }
    spc_error_set(err, SPC_ERR_IO, path, 0, 0, "too many levels of symbolic links");
    return false;
}

spc_status spc_output_resolve(const char *path, char *out, size_t size, spc_error *err)
{
    if (!path || !*path)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "empty output path");
    if (!follow_links(path, out, size, err))
        return SPC_ERR_IO;
    const char *via = strcmp(out, path) != 0 ? " (the target of the symbolic link)" : "";
    struct stat st;
    if (stat(out, &st) == 0) {
        const char *kind = S_ISDIR(st.st_mode)    ? "a directory"
                           : S_ISCHR(st.st_mode)  ? "a character device"
                           : S_ISBLK(st.st_mode)  ? "a block device"
                           : S_ISFIFO(st.st_mode) ? "a FIFO (named pipe)"
                           : S_ISSOCK(st.st_mode) ? "a socket"
                           : S_ISREG(st.st_mode)  ? NULL
                                                  : "not a regular file";
        if (kind)
            return spc_error_set(err, SPC_ERR_IO, path, 0, 0,
                                 "'%s'%s is %s: only a regular file (or a new name) can be written as an output",
                                 out, via, kind);
    } else if (errno != ENOENT) {
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot examine '%s'%s: %s", out, via, strerror(errno));
    }
    /* the folder that will hold the temporary file and the result */
    char dir[4096];
    const char *slash = strrchr(out, '/');
    if (!slash)
        snprintf(dir, sizeof dir, ".");
    else if (slash == out)
        snprintf(dir, sizeof dir, "/");
    else
        snprintf(dir, sizeof dir, "%.*s", (int)(slash - out), out);
    if (stat(dir, &st) != 0)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "the folder '%s'%s cannot be used: %s", dir, via,
                             strerror(errno));
    if (!S_ISDIR(st.st_mode))
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "'%s'%s is not a folder", dir, via);
    if (access(dir, W_OK | X_OK) != 0)
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "the folder '%s'%s is not writable: %s", dir, via,
                             strerror(errno));
    return SPC_OK;
}

spc_status spc_output_check(const char *path, spc_error *err)
{
    char resolved[4096];
    return spc_output_resolve(path, resolved, sizeof resolved, err);
}

int spc_atomic_open(const char *path, char *tmp, size_t tmpsize, spc_error *err)
{
    char target[4096];
    if (spc_output_resolve(path, target, sizeof target, err) != SPC_OK)
        return -1;
    int len = snprintf(tmp, tmpsize, "%s.tmp-%ld", target, (long)getpid());
    if (len < 0 || (size_t)len >= tmpsize) {
        spc_error_set(err, SPC_ERR_IO, path, 0, 0, "path too long");
        return -1;
    }
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0) {
        spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot create '%s': %s", tmp, strerror(errno));
        return -1;
    }
    return fd;
}

void spc_atomic_abort(int fd, const char *tmp)
{
    if (fd >= 0)
        close(fd);
    unlink(tmp);
}

/* Makes the rename durable: fsync the directory that holds path (best effort). */
static void sync_parent_dir(const char *path)
{
    size_t len = strlen(path);
    char *copy = malloc(len + 1);
    if (!copy)
        return;
    memcpy(copy, path, len + 1);
    int dfd = open(dirname(copy), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        fsync(dfd);
        close(dfd);
    }
    free(copy);
}

spc_status spc_atomic_commit(int fd, const char *tmp, const char *path, spc_error *err)
{
    if (fsync(fd) != 0) {
        int e = errno;
        spc_atomic_abort(fd, tmp);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot flush '%s': %s", tmp, strerror(e));
    }
    if (close(fd) != 0) {
        int e = errno;
        unlink(tmp);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot close '%s': %s", tmp, strerror(e));
    }
    /* tmp is "<target>.tmp-<pid>" (spc_atomic_open): the file replaced is the symbolic link's
     * target, never the link, and tmp lies in the target's folder so the rename is atomic */
    char suffix[32], target[4096];
    int ls = snprintf(suffix, sizeof suffix, ".tmp-%ld", (long)getpid());
    size_t lt = strlen(tmp);
    if (ls <= 0 || lt <= (size_t)ls || lt - (size_t)ls >= sizeof target || strcmp(tmp + lt - (size_t)ls, suffix)) {
        unlink(tmp);
        return spc_error_set(err, SPC_ERR_INTERNAL, path, 0, 0, "'%s' is not a temporary name of it", tmp);
    }
    memcpy(target, tmp, lt - (size_t)ls);
    target[lt - (size_t)ls] = '\0';
    /* the target may have changed kind while it was written: never rename over a non-file */
    struct stat st;
    if (lstat(target, &st) == 0 && !S_ISREG(st.st_mode)) {
        unlink(tmp);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "'%s' is no longer a regular file: not replaced", target);
    }
    if (rename(tmp, target) != 0) {
        int e = errno;
        unlink(tmp);
        return spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot rename '%s' to '%s': %s", tmp, target,
                             strerror(e));
    }
    sync_parent_dir(target);
    return SPC_OK;
}

bool spc_write_all(int fd, const void *buf, size_t size)
{
    const unsigned char *p = buf;
    while (size > 0) {
        ssize_t w = write(fd, p, size);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (w == 0) {
            errno = EIO;
            return false;
        }
        p += w;
        size -= (size_t)w;
    }
    return true;
}

spc_status spc_raster_write(const char *path, const char *format, const char *header, size_t rowbytes, int width,
                            int height, const float *rgb, spc_row_encoder encode, spc_error *err)
{
    if (width <= 0 || height <= 0 || !rgb)
        return spc_error_set(err, SPC_ERR_VALUE, path, 0, 0, "invalid %s write request (%dx%d)", format, width,
                             height);
    size_t tmpsize = strlen(path) + 64;
    char *tmp = malloc(tmpsize);
    unsigned char *row = malloc(rowbytes);
    if (!tmp || !row) {
        free(tmp);
        free(row);
        return spc_error_set(err, SPC_ERR_NOMEM, path, 0, 0, "out of memory");
    }
    int fd = spc_atomic_open(path, tmp, tmpsize, err);
    if (fd < 0) {
        free(tmp);
        free(row);
        return SPC_ERR_IO;
    }
    bool ok = spc_write_all(fd, header, strlen(header));
    for (int i = 0; ok && i < height; ++i) {
        encode(rgb, width, height, i, row);
        ok = spc_write_all(fd, row, rowbytes);
    }
    spc_status st;
    if (ok) {
        st = spc_atomic_commit(fd, tmp, path, err);
    } else {
        int e = errno;
        spc_atomic_abort(fd, tmp);
        st = spc_error_set(err, SPC_ERR_IO, path, 0, 0, "cannot write %s: %s", format, strerror(e));
    }
    free(tmp);
    free(row);
    return st;
}
