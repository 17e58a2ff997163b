/* cli/smio.h - the one I/O layer under every file the `supermat` CLI touches (io.c and batch.c, C;
 * mesh.cpp, C++). POSIX (on Windows through cli/win32.h); static functions only, included where used. docs/security.md states what it
 * promises; tests/test_hostile.sh checks it.
 *
 * Reading
 *   smio_open_regular   opens a path without blocking (O_NONBLOCK: a FIFO never stalls the run), fstat()s
 *                       it, and keeps it only when it is a regular file; then reads block as usual.
 *   smio_ref_syntax     a reference inside an asset (a glTF URI, decoded) must be a relative path: absolute
 *                       paths, drive letters, backslashes (UNC, Windows paths) and schemes (file:, http:)
 *                       are refused with the reason.
 *   smio_inside         after every symbolic link is resolved, is a path inside a folder?
 * Writing
 *   smio_dir_open       the folder REL below an output folder ROOT, each component opened with O_NOFOLLOW
 *                       (and created with mkdirat when asked): a link planted inside ROOT is refused, never
 *                       followed. ROOT itself is the user's choice and may be a link.
 *   smio_tmp_create     a new, uniquely named temporary file beside NAME (".NAME.<pid>-<n>-<host>.supermat.tmp"),
 *                       created with O_CREAT | O_EXCL | O_NOFOLLOW: never an existing file or link.
 *   (the caller writes, fsync()s, then renameat()s or linkat()s it to NAME: neither follows a link)
 * Cleaning
 *   smio_rmtree_at      removes a folder below a folder descriptor with unlinkat(), never following a link.
 *   smio_clean_stale    removes what a dead run of the tool on this machine left in a folder (<host>, a hash
 *                       of the host name, is this machine's: a run on another machine sharing the folder
 *                       is never taken for dead): its temporary files (the name above, a regular file, a
 *                       pid that no longer runs) and its staging folders
 *                       (".supermat-mesh-<pid>-<n>-<host>.tmp", a real folder holding the marker file
 *                       SMIO_STAGE_MARKER, a pid that no longer runs; or empty: a kill between its
 *                       marker's removal and its own). Nothing else is ever removed.
 *   smio_stage_create   a staging folder of this process (0700: nobody else can plant a link in it), with
 *                       its marker.
 */
#ifndef SUPERMAT_CLI_SMIO_H
#define SUPERMAT_CLI_SMIO_H

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>
#if defined(_WIN32)
#include "win32.h" /* the calls below over the Win32 wide API (UTF-8 paths; reparse points are links) */
#endif

#ifndef O_CLOEXEC
#define O_CLOEXEC 0
#endif

#if defined(__GNUC__) || defined(__clang__)
#define SMIO_API static __attribute__((unused))
#else
#define SMIO_API static
#endif

#define SMIO_STAGE_MARKER ".supermat-stage"
#define SMIO_STAGE_PREFIX ".supermat-mesh-"
#define SMIO_TMP_SUFFIX ".supermat.tmp"

/* what a file is, for messages */
SMIO_API const char *smio_kind(mode_t m) {
    if (S_ISDIR(m)) return "a folder";
    if (S_ISFIFO(m)) return "a FIFO";
    if (S_ISCHR(m) || S_ISBLK(m)) return "a device";
    if (S_ISSOCK(m)) return "a socket";
    if (S_ISLNK(m)) return "a symbolic link";
    return "not a regular file";
}

/* path opened for reading when it is a regular file: the descriptor, or -1, why in msg and errno (open's, or
   EINVAL: not a regular file). With nofollow a symbolic link as the last component is refused too. Never
   blocks on a FIFO or a device. */
SMIO_API int smio_open_regular(const char *path, int nofollow, char *msg, size_t cap) {
    struct stat st;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC | (nofollow ? O_NOFOLLOW : 0)), fl;
    if (fd < 0) {
        int e = errno;
        snprintf(msg, cap, "%s", nofollow && e == ELOOP ? "is a symbolic link" : strerror(e));
        errno = e;
        return -1;
    }
    memset(&st, 0, sizeof st);
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        snprintf(msg, cap, "is %s, not a regular file", smio_kind(st.st_mode));
        close(fd);
        errno = EINVAL;
        return -1;
    }
    fl = fcntl(fd, F_GETFL);
    if (fl != -1) (void)fcntl(fd, F_SETFL, fl & ~O_NONBLOCK);
    return fd;
}

/* reads n bytes at the descriptor's position; 0, or -1 with errno (0 when the file got shorter) */
SMIO_API int smio_read_all(int fd, unsigned char *buf, size_t n) {
    size_t got = 0;
    while (got < n) {
        size_t chunk = n - got > ((size_t)1 << 30) ? ((size_t)1 << 30) : n - got;
        ssize_t r = read(fd, buf + got, chunk);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) { if (r == 0) errno = 0; return -1; }
        got += (size_t)r;
    }
    return 0;
}

/* a reference inside an asset (a decoded URI): NULL when it is a relative path, else why it is refused */
SMIO_API const char *smio_ref_syntax(const char *u) {
    const char *p;
    if (!u[0]) return "is empty";
    if (u[0] == '/') return "is an absolute path";
    if (strchr(u, '\\')) return "holds a backslash (a Windows or UNC path)";
    if (isalpha((unsigned char)u[0]) && u[1] == ':') return "names a drive";
    for (p = u; *p && *p != '/'; p++)
        if (*p == ':') return "is a URI with a scheme (file:, http:, ...): only relative paths are read";
    return NULL;
}

/* 1 when path, every symbolic link resolved, lies inside the folder real_dir (itself resolved), 0 when
   outside, -1 when it does not resolve (errno); *resolved (malloc'ed) gets the resolved path when not NULL */
SMIO_API int smio_inside(const char *real_dir, const char *path, char **resolved) {
    char *r = realpath(path, NULL);
    size_t n = strlen(real_dir);
    int in;
    if (resolved) *resolved = NULL;
    if (!r) return -1;
    in = !strcmp(real_dir, "/") || (!strncmp(r, real_dir, n) && (r[n] == '/' || r[n] == 0));
    if (resolved) *resolved = r;
    else free(r);
    return in;
}

/* the folder rel ("" = root, components separated by '/') below root, opened without following a link
   below root; create: missing folders are made. The descriptor, or -1 and why in msg. */
SMIO_API int smio_dir_open(const char *root, const char *rel, int create, char *msg, size_t cap) {
    int fd = open(root[0] ? root : ".", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    const char *p = rel;
    if (fd < 0) { snprintf(msg, cap, "cannot open folder '%s': %s", root, strerror(errno)); return -1; }
    while (*p) {
        char comp[256];
        size_t n = strcspn(p, "/");
        int nfd;
        if (n == 0) { p++; continue; }
        if (n >= sizeof comp) { snprintf(msg, cap, "a folder name in '%s' is too long", rel); close(fd); return -1; }
        memcpy(comp, p, n);
        comp[n] = 0;
        p += n;
        if (!strcmp(comp, ".") || !strcmp(comp, "..")) { snprintf(msg, cap, "'%s' below '%s' holds '%s'", rel, root, comp); close(fd); return -1; }
        nfd = openat(fd, comp, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        if (nfd < 0 && errno == ENOENT && create) {
            if (mkdirat(fd, comp, 0777) != 0 && errno != EEXIST) {
                snprintf(msg, cap, "cannot create folder '%s/%.*s': %s", root, (int)(p - rel), rel, strerror(errno));
                close(fd);
                return -1;
            }
            nfd = openat(fd, comp, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
        }
        if (nfd < 0) {
            struct stat st;
            int e = errno;
            if (fstatat(fd, comp, &st, AT_SYMLINK_NOFOLLOW) == 0 && (S_ISLNK(st.st_mode) || !S_ISDIR(st.st_mode)))
                snprintf(msg, cap, "'%s/%.*s' is %s inside the output folder, not a folder: refused (it is never followed)", root,
                         (int)(p - rel), rel, S_ISLNK(st.st_mode) ? "a symbolic link" : smio_kind(st.st_mode));
            else
                snprintf(msg, cap, "cannot open folder '%s/%.*s': %s", root, (int)(p - rel), rel, strerror(e));
            close(fd);
            return -1;
        }
        close(fd);
        fd = nfd;
    }
    return fd;
}

/* this machine's tag in the names of temporary files and stages: FNV-1a of the host name, 8 hex digits */
SMIO_API unsigned long smio_host_tag(void) {
    static unsigned long tag;
    static int done;
    if (!done) {
        char host[256] = "";
        const unsigned char *p;
        unsigned long h = 2166136261u;
        if (gethostname(host, sizeof host - 1) != 0) host[0] = 0;
        host[sizeof host - 1] = 0;
        for (p = (const unsigned char *)host; *p; p++) h = ((h ^ *p) * 16777619u) & 0xffffffffu;
        tag = h;
        done = 1;
    }
    return tag;
}

/* a new temporary file beside name in folder dirfd, named ".NAME.<pid>-<n>-<host>.supermat.tmp" (NAME cut to
   180 bytes), created exclusively, never through a link; the descriptor (tmp gets its name), or -1 (errno) */
SMIO_API int smio_tmp_create(int dirfd, const char *name, char *tmp, size_t cap) {
    static unsigned long counter;
    int k;
    for (k = 0; k < 1000; k++) {
        int fd;
        unsigned long n = counter++ * 2654435761u ^ (unsigned long)time(NULL) ^ (unsigned long)k;
        snprintf(tmp, cap, ".%.180s.%ld-%lx-%08lx" SMIO_TMP_SUFFIX, name, (long)getpid(), n & 0xffffffu, smio_host_tag());
        fd = openat(dirfd, tmp, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd >= 0 || errno != EEXIST) return fd;
    }
    errno = EEXIST;
    return -1;
}

/* removes folder name below parent (and everything in it) with unlinkat; a link is removed, never followed */
SMIO_API void smio_rmtree_at(int parent, const char *name, int depth) {
    int fd;
    DIR *d;
    struct dirent *e;
    if (depth > 64) return;
    fd = openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) { (void)unlinkat(parent, name, 0); return; } /* not a folder (or a link): the name alone */
    if (!(d = fdopendir(fd))) { close(fd); return; }
    while ((e = readdir(d)) != NULL) {
        struct stat st;
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..") || !strcmp(e->d_name, SMIO_STAGE_MARKER)) continue;
        if (fstatat(fd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISDIR(st.st_mode)) smio_rmtree_at(fd, e->d_name, depth + 1);
        else (void)unlinkat(fd, e->d_name, 0);
    }
    (void)unlinkat(fd, SMIO_STAGE_MARKER, 0); /* a stage's marker goes last: killed before, it is still ours to clean */
    closedir(d);
    (void)unlinkat(parent, name, AT_REMOVEDIR);
}

/* 1 when no process has this pid (a dead run's leftovers), 0 when one runs (or may) */
SMIO_API int smio_pid_gone(long pid) {
    if (pid <= 0 || (pid_t)pid == getpid()) return 0;
    return kill((pid_t)pid, 0) != 0 && errno == ESRCH;
}

/* the pid in ".NAME.<pid>-<hex>-<host>.supermat.tmp" or ".supermat-mesh-<pid>-<hex>-<host>.tmp" made on this
   machine; 0 when the name is not one of ours, or was made on another machine */
SMIO_API long smio_leftover_pid(const char *name, int *stage) {
    size_t n = strlen(name), s = strlen(SMIO_TMP_SUFFIX);
    const char *p, *q;
    long pid = 0;
    *stage = 0;
    if (!strncmp(name, SMIO_STAGE_PREFIX, strlen(SMIO_STAGE_PREFIX)) && n > 4 && !strcmp(name + n - 4, ".tmp")) {
        p = name + strlen(SMIO_STAGE_PREFIX);
        *stage = 1;
    } else if (name[0] == '.' && n > s && !strcmp(name + n - s, SMIO_TMP_SUFFIX)) {
        for (q = name + n - s; q > name && q[-1] != '.'; q--) {}
        p = q;
        if (p == name) return 0;
    } else
        return 0;
    if (!isdigit((unsigned char)*p)) return 0;
    while (isdigit((unsigned char)*p)) { pid = pid * 10 + (*p - '0'); if (pid > 1L << 30) return 0; p++; }
    if (*p != '-') return 0;
    for (p++; isxdigit((unsigned char)*p); p++) {}
    if (*p != '-' || strtoul(p + 1, (char **)&q, 16) != smio_host_tag() || q != p + 9) return 0;
    return !strcmp(q, *stage ? ".tmp" : SMIO_TMP_SUFFIX) ? pid : 0;
}

/* removes what dead runs of the tool left in folder dirfd (see the top); returns how many */
SMIO_API int smio_clean_stale(int dirfd) {
    int fd = dup(dirfd), n = 0;
    DIR *d;
    struct dirent *e;
    if (fd < 0) return 0;
    if (!(d = fdopendir(fd))) { close(fd); return 0; }
    rewinddir(d);
    while ((e = readdir(d)) != NULL) {
        struct stat st;
        int stage = 0;
        long pid = smio_leftover_pid(e->d_name, &stage);
        if (!pid || !smio_pid_gone(pid) || fstatat(dirfd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
        if (!stage && S_ISREG(st.st_mode)) {
            if (unlinkat(dirfd, e->d_name, 0) == 0) n++;
        } else if (stage && S_ISDIR(st.st_mode)) {
            int sfd = openat(dirfd, e->d_name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
            struct stat mst;
            int marked = sfd >= 0 && fstatat(sfd, SMIO_STAGE_MARKER, &mst, AT_SYMLINK_NOFOLLOW) == 0 && S_ISREG(mst.st_mode);
            if (sfd >= 0) close(sfd);
            if (marked) { smio_rmtree_at(dirfd, e->d_name, 0); n++; }
            else if (unlinkat(dirfd, e->d_name, AT_REMOVEDIR) == 0) n++; /* empty (killed at its last step): holds nothing */
        }
    }
    closedir(d);
    return n;
}

/* a new staging folder of this process below dirfd, with its marker; 0 (name gets it) or -1 (errno) */
SMIO_API int smio_stage_create(int dirfd, char *name, size_t cap) {
    static unsigned long counter;
    int k;
    for (k = 0; k < 1000; k++) {
        unsigned long n = counter++ * 2654435761u ^ (unsigned long)time(NULL) ^ (unsigned long)k;
        snprintf(name, cap, SMIO_STAGE_PREFIX "%ld-%lx-%08lx.tmp", (long)getpid(), n & 0xffffffu, smio_host_tag());
        if (mkdirat(dirfd, name, 0700) == 0) { /* private: nothing can be planted in it */
            int sfd = openat(dirfd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC), mfd = -1;
            if (sfd >= 0) mfd = openat(sfd, SMIO_STAGE_MARKER, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
            if (mfd >= 0) {
                char line[64];
                int len = snprintf(line, sizeof line, "supermat staging folder of pid %ld\n", (long)getpid());
                int ok = write(mfd, line, (size_t)len) == len;
                close(mfd);
                close(sfd);
                if (ok) return 0;
            } else if (sfd >= 0)
                close(sfd);
            smio_rmtree_at(dirfd, name, 0);
            return -1;
        }
        if (errno != EEXIST) return -1;
    }
    errno = EEXIST;
    return -1;
}

#endif
