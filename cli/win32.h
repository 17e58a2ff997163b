/* cli/win32.h - the POSIX calls the `supermat` CLI makes, on Windows (MinGW-w64; issue 62): one place, so that
 * the commands and the I/O layer (smio.h, io.c, batch.c, download.c) keep one source. Included by smio.h
 * after the C library's headers, only when _WIN32 is defined; static functions only.
 *
 *   paths       UTF-8 everywhere (main() takes its arguments from GetCommandLineW: cli_platform_args), turned
 *               into UTF-16 for the wide API (CreateFileW, MoveFileExW, FindFirstFileW ...) at each call.
 *               The arguments' and the environment's backslashes become '/' (the CLI splits paths at '/';
 *               Windows takes either): C:\maps\a.png is C:/maps/a.png.
 *   descriptors files are C-runtime descriptors over CreateFileW handles (_open_osfhandle), so fdopen, read,
 *               write, fstat keep working; a folder opened with O_DIRECTORY is a descriptor too (a handle
 *               opened with FILE_FLAG_BACKUP_SEMANTICS and no FILE_SHARE_DELETE: the folder cannot be renamed
 *               or removed while it is held), with its path kept beside it for the *at() calls.
 *   links       a reparse point (symbolic link, junction, mount point) is what a symbolic link is on Linux:
 *               lstat/fstatat(AT_SYMLINK_NOFOLLOW) report S_IFLNK, and open(O_NOFOLLOW) / openat(O_NOFOLLOW)
 *               opens it with FILE_FLAG_OPEN_REPARSE_POINT and refuses it (ELOOP), never following it.
 *   writes      renameat = MoveFileExW(MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH) (atomic replace on
 *               NTFS, a link at the target replaced, not followed); linkat = CreateHardLinkW (fails on an
 *               existing name: EEXIST); fsync = FlushFileBuffers.
 *   the rest    mmap (CreateFileMappingW + MapViewOfFile, read-only), opendir/readdir (FindFirstFileW),
 *               realpath (GetFinalPathNameByHandleW), kill(pid, 0) (OpenProcess), flock (LockFileEx on a
 *               byte far past any end of file: an advisory lock that blocks no reading), getline,
 *               statvfs (GetDiskFreeSpaceExW), getrusage (peak working set), open_memstream (a temporary
 *               file deleted on close: cli_memstream_*).
 * Errors set errno from GetLastError() (smw_errno). */
#ifndef SUPERMAT_CLI_WIN32_H
#define SUPERMAT_CLI_WIN32_H

#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#ifndef NOMINMAX
#define NOMINMAX
#endif
#include <windows.h>
#include <shellapi.h>
#include <psapi.h>
#include <direct.h>
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <io.h>
#include <process.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <dirent.h>
#include <unistd.h>

#if defined(__GNUC__) || defined(__clang__)
#define SMW_API static __attribute__((unused))
#else
#define SMW_API static
#endif

/* ---- errors, paths ---- */
SMW_API int smw_errno_of(DWORD e) {
    switch (e) {
    case ERROR_FILE_NOT_FOUND: case ERROR_PATH_NOT_FOUND: case ERROR_INVALID_DRIVE: case ERROR_BAD_NETPATH: case ERROR_BAD_NET_NAME: return ENOENT;
    case ERROR_ACCESS_DENIED: case ERROR_SHARING_VIOLATION: case ERROR_LOCK_VIOLATION: case ERROR_CANNOT_MAKE: return EACCES;
    case ERROR_FILE_EXISTS: case ERROR_ALREADY_EXISTS: return EEXIST;
    case ERROR_DIRECTORY: return ENOTDIR;
    case ERROR_DISK_FULL: case ERROR_HANDLE_DISK_FULL: return ENOSPC;
    case ERROR_WRITE_PROTECT: return EROFS;
    case ERROR_DIR_NOT_EMPTY: return ENOTEMPTY;
    case ERROR_NOT_SAME_DEVICE: return EXDEV;
    case ERROR_FILENAME_EXCED_RANGE: return ENAMETOOLONG;
    case ERROR_INVALID_NAME: case ERROR_INVALID_PARAMETER: return EINVAL;
    case ERROR_NOT_ENOUGH_MEMORY: case ERROR_OUTOFMEMORY: return ENOMEM;
    case ERROR_CANT_RESOLVE_FILENAME: return ELOOP;
    default: return EIO;
    }
}
SMW_API int smw_fail(void) { errno = smw_errno_of(GetLastError()); return -1; }

/* a malloc'ed UTF-16 copy of the UTF-8 string s (n bytes, or -1: up to its NUL), or NULL (errno) */
SMW_API wchar_t *smw_wide_n(const char *s, int n) {
    int k = MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, s, n, NULL, 0);
    wchar_t *w;
    if (k <= 0 && n != 0) { errno = EINVAL; return NULL; }
    if (!(w = (wchar_t *)malloc(((size_t)k + 1) * sizeof *w))) { errno = ENOMEM; return NULL; }
    if (k > 0) MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, s, n, w, k);
    w[k > 0 ? k : 0] = 0;
    if (n < 0 && k > 0) w[k - 1] = 0;
    return w;
}
SMW_API wchar_t *smw_wide(const char *s) { return smw_wide_n(s, -1); }
/* a malloc'ed UTF-8 copy of the UTF-16 string w, or NULL */
SMW_API char *smw_utf8(const wchar_t *w) {
    int k = WideCharToMultiByte(CP_UTF8, 0, w, -1, NULL, 0, NULL, NULL);
    char *s;
    if (k <= 0 || !(s = (char *)malloc((size_t)k))) { errno = ENOMEM; return NULL; }
    WideCharToMultiByte(CP_UTF8, 0, w, -1, s, k, NULL, NULL);
    return s;
}

/* ---- folder descriptors: the path of each, by descriptor ---- */
#define SMW_MAXFD 4096
static wchar_t *smw_dirpath[SMW_MAXFD];
static CRITICAL_SECTION smw_lock;
static volatile LONG smw_lock_state; /* 0 not made, 1 being made, 2 ready */
SMW_API void smw_locked(int on) {
    if (smw_lock_state != 2) {
        if (InterlockedCompareExchange(&smw_lock_state, 1, 0) == 0) { InitializeCriticalSection(&smw_lock); smw_lock_state = 2; }
        else while (smw_lock_state != 2) Sleep(0);
    }
    if (on) EnterCriticalSection(&smw_lock);
    else LeaveCriticalSection(&smw_lock);
}
/* a malloc'ed "DIR\NAME" in UTF-16 for a name below folder descriptor fd (AT_FDCWD: the name alone) */
#define AT_FDCWD (-100)
SMW_API wchar_t *smw_at(int fd, const char *name) {
    wchar_t *n = smw_wide(name), *d, *p;
    size_t a, b;
    if (n && fd == AT_FDCWD && iswalpha(n[0]) && n[1] == L':' && !n[2]) { /* "C:" (the folder of "C:/x.png") is the drive's root */
        wchar_t *r = (wchar_t *)realloc(n, 4 * sizeof *n);
        if (!r) { free(n); errno = ENOMEM; return NULL; }
        r[2] = L'\\';
        r[3] = 0;
        return r;
    }
    if (!n || fd == AT_FDCWD) return n;
    smw_locked(1);
    d = fd >= 0 && fd < SMW_MAXFD ? smw_dirpath[fd] : NULL;
    if (!d) { smw_locked(0); free(n); errno = EBADF; return NULL; }
    a = wcslen(d);
    b = wcslen(n);
    if ((p = (wchar_t *)malloc((a + b + 2) * sizeof *p)) != NULL) {
        memcpy(p, d, a * sizeof *p);
        if (a && p[a - 1] != L'\\' && p[a - 1] != L'/') p[a++] = L'\\';
        memcpy(p + a, n, (b + 1) * sizeof *p);
    }
    smw_locked(0);
    free(n);
    if (!p) errno = ENOMEM;
    return p;
}

/* ---- stat ---- */
#ifndef S_IFLNK
#define S_IFLNK 0xA000
#endif
#ifndef S_ISLNK
#define S_ISLNK(m) (((m) & S_IFMT) == S_IFLNK)
#endif
#ifndef S_ISSOCK
#define S_ISSOCK(m) 0
#endif
#ifndef S_ISBLK
#define S_ISBLK(m) 0
#endif
#ifndef S_ISFIFO
#define S_ISFIFO(m) (((m) & S_IFMT) == _S_IFIFO)
#endif
struct smw_stat {
    unsigned st_mode;
    long long st_size;
    unsigned long long st_dev, st_ino;
};
#define stat smw_stat
#define lstat smw_lstat
#define fstat smw_fstat
#define fstatat smw_fstatat
#define AT_SYMLINK_NOFOLLOW 0x100
#define AT_REMOVEDIR 0x200

SMW_API int smw_stat_handle(HANDLE h, struct smw_stat *st, int nofollow) {
    BY_HANDLE_FILE_INFORMATION fi;
    DWORD t = GetFileType(h);
    memset(st, 0, sizeof *st);
    if (t == FILE_TYPE_PIPE) { st->st_mode = _S_IFIFO; return 0; }
    if (t == FILE_TYPE_CHAR) { st->st_mode = _S_IFCHR; return 0; }
    if (!GetFileInformationByHandle(h, &fi)) return smw_fail();
    if (nofollow && (fi.dwFileAttributes & FILE_ATTRIBUTE_REPARSE_POINT)) st->st_mode = S_IFLNK;
    else if (fi.dwFileAttributes & FILE_ATTRIBUTE_DIRECTORY) st->st_mode = _S_IFDIR | 0777;
    else st->st_mode = _S_IFREG | 0666;
    st->st_size = (long long)(((unsigned long long)fi.nFileSizeHigh << 32) | fi.nFileSizeLow);
    st->st_dev = fi.dwVolumeSerialNumber;
    st->st_ino = ((unsigned long long)fi.nFileIndexHigh << 32) | fi.nFileIndexLow;
    return 0;
}
SMW_API int smw_stat_w(const wchar_t *w, struct smw_stat *st, int nofollow) {
    HANDLE h = CreateFileW(w, FILE_READ_ATTRIBUTES, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, NULL, OPEN_EXISTING,
                           FILE_FLAG_BACKUP_SEMANTICS | (nofollow ? FILE_FLAG_OPEN_REPARSE_POINT : 0), NULL);
    int r;
    if (h == INVALID_HANDLE_VALUE) return smw_fail();
    r = smw_stat_handle(h, st, nofollow);
    CloseHandle(h);
    return r;
}
SMW_API int smw_stat_at(int fd, const char *path, struct smw_stat *st, int nofollow) {
    wchar_t *w = smw_at(fd, path);
    int r;
    if (!w) return -1;
    r = smw_stat_w(w, st, nofollow);
    free(w);
    return r;
}
SMW_API int smw_stat(const char *path, struct smw_stat *st) { return smw_stat_at(AT_FDCWD, path, st, 0); }
SMW_API int smw_lstat(const char *path, struct smw_stat *st) { return smw_stat_at(AT_FDCWD, path, st, 1); }
SMW_API int smw_fstatat(int fd, const char *name, struct smw_stat *st, int flags) { return smw_stat_at(fd, name, st, (flags & AT_SYMLINK_NOFOLLOW) != 0); }
SMW_API int smw_fstat(int fd, struct smw_stat *st) {
    HANDLE h = (HANDLE)_get_osfhandle(fd);
    if (h == INVALID_HANDLE_VALUE) { errno = EBADF; return -1; }
    return smw_stat_handle(h, st, 0);
}

/* ---- open ---- */
#ifndef O_NOFOLLOW
#define O_NOFOLLOW 0x1000000
#endif
#ifndef O_DIRECTORY
#define O_DIRECTORY 0x2000000
#endif
#ifndef O_NONBLOCK
#define O_NONBLOCK 0 /* no FIFO in a Windows folder to block on */
#endif
#ifndef O_NOCTTY
#define O_NOCTTY 0
#endif
#ifndef O_CLOEXEC
#define O_CLOEXEC _O_NOINHERIT
#endif
#define F_GETFL 3
#define F_SETFL 4
#define open smw_open
#define openat smw_openat
#define close smw_close
#define dup smw_dup
#define fcntl smw_fcntl
#define fsync smw_fsync

/* the descriptor of a CreateFileW of the UTF-16 path w with open()'s flags, or -1 (errno) */
SMW_API int smw_open_w(const wchar_t *w, int flags) {
    DWORD access, disp, share = FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, fl = FILE_FLAG_BACKUP_SEMANTICS;
    int acc = flags & (_O_RDONLY | _O_WRONLY | _O_RDWR), fd, crt = 0;
    HANDLE h;
    BY_HANDLE_FILE_INFORMATION fi;
    access = acc == _O_WRONLY ? GENERIC_WRITE : acc == _O_RDWR ? GENERIC_READ | GENERIC_WRITE : GENERIC_READ;
    if ((flags & _O_CREAT) && (flags & _O_EXCL)) disp = CREATE_NEW;
    else if ((flags & _O_CREAT) && (flags & _O_TRUNC)) disp = CREATE_ALWAYS;
    else if (flags & _O_CREAT) disp = OPEN_ALWAYS;
    else if (flags & _O_TRUNC) disp = TRUNCATE_EXISTING;
    else disp = OPEN_EXISTING;
    if (flags & O_NOFOLLOW) fl |= FILE_FLAG_OPEN_REPARSE_POINT;
    if (flags & O_DIRECTORY) { share = FILE_SHARE_READ | FILE_SHARE_WRITE; access = FILE_READ_ATTRIBUTES | FILE_LIST_DIRECTORY | SYNCHRONIZE; }
    h = CreateFileW(w, access, share, NULL, disp, fl, NULL);
    if (h == INVALID_HANDLE_VALUE) return smw_fail();
    if (GetFileType(h) == FILE_TYPE_DISK && GetFileInformationByHandle(h, &fi)) {
        if ((flags & O_NOFOLLOW) && (fi.dwFileAttributes & FILE_ATTRIBUTE_REPARSE_POINT)) { CloseHandle(h); errno = ELOOP; return -1; }
        if ((flags & O_DIRECTORY) && !(fi.dwFileAttributes & FILE_ATTRIBUTE_DIRECTORY)) { CloseHandle(h); errno = ENOTDIR; return -1; }
    } else if (flags & O_DIRECTORY) {
        CloseHandle(h);
        errno = ENOTDIR;
        return -1;
    }
    if (acc == _O_RDONLY) crt |= _O_RDONLY;
    if (flags & _O_APPEND) crt |= _O_APPEND;
    fd = _open_osfhandle((intptr_t)h, crt);
    if (fd < 0) { CloseHandle(h); errno = EMFILE; return -1; }
    _setmode(fd, _O_BINARY);
    if (flags & O_DIRECTORY) {
        DWORD n = GetFullPathNameW(w, 0, NULL, NULL);
        wchar_t *full = n ? (wchar_t *)malloc((n + 1) * sizeof *full) : NULL;
        if (!full || !GetFullPathNameW(w, n + 1, full, NULL) || fd >= SMW_MAXFD) { free(full); _close(fd); errno = ENOMEM; return -1; }
        smw_locked(1);
        free(smw_dirpath[fd]);
        smw_dirpath[fd] = full;
        smw_locked(0);
    }
    return fd;
}
SMW_API int smw_openat(int dirfd, const char *name, int flags, ...) {
    wchar_t *w = smw_at(dirfd, name);
    int fd;
    if (!w) return -1;
    fd = smw_open_w(w, flags);
    free(w);
    return fd;
}
SMW_API int smw_open(const char *path, int flags, ...) { return smw_openat(AT_FDCWD, path, flags); }
SMW_API int smw_close(int fd) {
    if (fd >= 0 && fd < SMW_MAXFD) {
        smw_locked(1);
        free(smw_dirpath[fd]);
        smw_dirpath[fd] = NULL;
        smw_locked(0);
    }
    return _close(fd);
}
SMW_API int smw_dup(int fd) {
    int d = _dup(fd);
    if (d >= 0 && d < SMW_MAXFD && fd >= 0 && fd < SMW_MAXFD) {
        smw_locked(1);
        free(smw_dirpath[d]);
        smw_dirpath[d] = smw_dirpath[fd] ? _wcsdup(smw_dirpath[fd]) : NULL;
        smw_locked(0);
    }
    return d;
}
SMW_API int smw_fcntl(int fd, int cmd, ...) { (void)fd; (void)cmd; return 0; }
SMW_API int smw_fsync(int fd) {
    HANDLE h = (HANDLE)_get_osfhandle(fd);
    DWORD e;
    if (h == INVALID_HANDLE_VALUE) { errno = EBADF; return -1; }
    if (FlushFileBuffers(h)) return 0;
    e = GetLastError();
    if (e == ERROR_ACCESS_DENIED) { /* opened for reading (POSIX syncs those too): a writable handle to the same file */
        HANDLE w = ReOpenFile(h, GENERIC_WRITE, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, 0);
        if (w != INVALID_HANDLE_VALUE) {
            BOOL ok = FlushFileBuffers(w);
            e = ok ? 0 : GetLastError();
            CloseHandle(w);
            if (ok) return 0;
        }
    }
    errno = e == ERROR_ACCESS_DENIED || e == ERROR_INVALID_HANDLE || e == ERROR_INVALID_FUNCTION ? EINVAL : smw_errno_of(e); /* a folder */
    return -1;
}

/* ---- names: make, remove, rename, link ---- */
#define mkdir(p, m) smw_mkdirat(AT_FDCWD, (p), (m))
#define mkdirat smw_mkdirat
#define unlink(p) smw_unlinkat(AT_FDCWD, (p), 0)
#define unlinkat smw_unlinkat
#define rename(a, b) smw_renameat(AT_FDCWD, (a), AT_FDCWD, (b))
#define renameat smw_renameat
#define linkat smw_linkat
SMW_API int smw_mkdirat(int fd, const char *name, int mode) {
    wchar_t *w;
    BOOL ok;
    (void)mode;
    if (fd == AT_FDCWD && ((isalpha((unsigned char)name[0]) && name[1] == ':' && !name[2]) || !strcmp(name, "/") || !strcmp(name, "//"))) {
        errno = EEXIST; /* a drive, the root (mkdir -p on "C:/maps" starts there) */
        return -1;
    }
    if (!(w = smw_at(fd, name))) return -1;
    ok = CreateDirectoryW(w, NULL);
    free(w);
    return ok ? 0 : smw_fail();
}
SMW_API int smw_unlinkat(int fd, const char *name, int flags) {
    wchar_t *w = smw_at(fd, name);
    BOOL ok;
    if (!w) return -1;
    if (flags & AT_REMOVEDIR) ok = RemoveDirectoryW(w); /* a junction or a folder link: the link goes, not its target */
    else {
        DWORD a = GetFileAttributesW(w);
        if (a != INVALID_FILE_ATTRIBUTES && (a & FILE_ATTRIBUTE_DIRECTORY)) {
            if (a & FILE_ATTRIBUTE_REPARSE_POINT) ok = RemoveDirectoryW(w); /* a link to a folder is a name, as on Linux */
            else { free(w); errno = EISDIR; return -1; }
        } else {
            ok = DeleteFileW(w);
            if (!ok && GetLastError() == ERROR_ACCESS_DENIED && a != INVALID_FILE_ATTRIBUTES && (a & FILE_ATTRIBUTE_READONLY)) {
                SetFileAttributesW(w, a & ~(DWORD)FILE_ATTRIBUTE_READONLY); /* POSIX removes a read-only file */
                ok = DeleteFileW(w);
            }
        }
    }
    free(w);
    return ok ? 0 : smw_fail();
}
SMW_API int smw_renameat(int fd1, const char *a, int fd2, const char *b) {
    wchar_t *wa = smw_at(fd1, a), *wb = wa ? smw_at(fd2, b) : NULL;
    BOOL ok;
    if (!wb) { free(wa); return -1; }
    ok = MoveFileExW(wa, wb, MOVEFILE_REPLACE_EXISTING | MOVEFILE_WRITE_THROUGH);
    free(wa);
    free(wb);
    return ok ? 0 : smw_fail();
}
SMW_API int smw_linkat(int fd1, const char *a, int fd2, const char *b, int flags) {
    wchar_t *wa = smw_at(fd1, a), *wb = wa ? smw_at(fd2, b) : NULL;
    BOOL ok;
    (void)flags;
    if (!wb) { free(wa); return -1; }
    ok = CreateHardLinkW(wb, wa, NULL);
    free(wa);
    free(wb);
    return ok ? 0 : smw_fail();
}

/* ---- folders: opendir / fdopendir / readdir ---- */
#define DIR smw_DIR
#define dirent smw_dirent
#define opendir smw_opendir
#define fdopendir smw_fdopendir
#define readdir smw_readdir
#define rewinddir smw_rewinddir
#define closedir smw_closedir
struct smw_dirent { char d_name[1024]; };
typedef struct smw_DIR {
    wchar_t *pattern; /* "DIR\*" */
    HANDLE h;
    WIN32_FIND_DATAW fd;
    int first, fdesc;  /* first: fd holds an entry not returned yet; fdesc: fdopendir's descriptor (closed by closedir) */
    struct smw_dirent e;
} smw_DIR;
SMW_API smw_DIR *smw_opendir_w(const wchar_t *dir, int fdesc) {
    size_t n = wcslen(dir);
    smw_DIR *d = (smw_DIR *)calloc(1, sizeof *d);
    if (!d || !(d->pattern = (wchar_t *)malloc((n + 3) * sizeof(wchar_t)))) { free(d); errno = ENOMEM; return NULL; }
    memcpy(d->pattern, dir, n * sizeof(wchar_t));
    if (n && dir[n - 1] != L'\\' && dir[n - 1] != L'/') d->pattern[n++] = L'\\';
    d->pattern[n++] = L'*';
    d->pattern[n] = 0;
    d->h = FindFirstFileW(d->pattern, &d->fd);
    if (d->h == INVALID_HANDLE_VALUE) {
        DWORD e = GetLastError();
        if (e != ERROR_FILE_NOT_FOUND && e != ERROR_NO_MORE_FILES) { free(d->pattern); free(d); errno = smw_errno_of(e); return NULL; }
    } else
        d->first = 1;
    d->fdesc = fdesc;
    return d;
}
SMW_API smw_DIR *smw_opendir(const char *path) {
    wchar_t *w = smw_wide(path);
    smw_DIR *d;
    struct smw_stat st;
    if (!w) return NULL;
    if (smw_stat_w(w, &st, 0) != 0) { free(w); return NULL; }
    if (!S_ISDIR(st.st_mode)) { free(w); errno = ENOTDIR; return NULL; }
    d = smw_opendir_w(w, -1);
    free(w);
    return d;
}
SMW_API smw_DIR *smw_fdopendir(int fd) {
    wchar_t *p = NULL;
    smw_DIR *d;
    smw_locked(1);
    if (fd >= 0 && fd < SMW_MAXFD && smw_dirpath[fd]) p = _wcsdup(smw_dirpath[fd]);
    smw_locked(0);
    if (!p) { errno = EBADF; return NULL; }
    d = smw_opendir_w(p, fd);
    free(p);
    return d;
}
SMW_API struct smw_dirent *smw_readdir(smw_DIR *d) {
    char *u;
    if (d->h == INVALID_HANDLE_VALUE) return NULL;
    if (!d->first && !FindNextFileW(d->h, &d->fd)) return NULL;
    d->first = 0;
    if (!(u = smw_utf8(d->fd.cFileName))) return NULL;
    snprintf(d->e.d_name, sizeof d->e.d_name, "%s", u);
    free(u);
    return &d->e;
}
SMW_API void smw_rewinddir(smw_DIR *d) {
    if (d->h != INVALID_HANDLE_VALUE) FindClose(d->h);
    d->h = FindFirstFileW(d->pattern, &d->fd);
    d->first = d->h != INVALID_HANDLE_VALUE;
}
SMW_API int smw_closedir(smw_DIR *d) {
    if (d->h != INVALID_HANDLE_VALUE) FindClose(d->h);
    if (d->fdesc >= 0) smw_close(d->fdesc);
    free(d->pattern);
    free(d);
    return 0;
}

/* ---- realpath: the path of what the name leads to, '/' between components ---- */
#define realpath smw_realpath
SMW_API char *smw_realpath(const char *path, char *resolved) {
    wchar_t *w = smw_wide(path), *f = NULL, *s;
    HANDLE h;
    DWORD n;
    char *u, *p;
    if (!w) return NULL;
    h = CreateFileW(w, FILE_READ_ATTRIBUTES, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, NULL, OPEN_EXISTING, FILE_FLAG_BACKUP_SEMANTICS, NULL);
    free(w);
    if (h == INVALID_HANDLE_VALUE) { smw_fail(); return NULL; }
    n = GetFinalPathNameByHandleW(h, NULL, 0, FILE_NAME_NORMALIZED | VOLUME_NAME_DOS);
    if (n) f = (wchar_t *)malloc((n + 1) * sizeof *f);
    if (!f || !GetFinalPathNameByHandleW(h, f, n + 1, FILE_NAME_NORMALIZED | VOLUME_NAME_DOS)) { CloseHandle(h); free(f); errno = ENOMEM; return NULL; }
    CloseHandle(h);
    s = f;
    if (!wcsncmp(s, L"\\\\?\\UNC\\", 8)) { s += 6; s[0] = L'\\'; }
    else if (!wcsncmp(s, L"\\\\?\\", 4)) s += 4;
    u = smw_utf8(s);
    free(f);
    if (!u) return NULL;
    for (p = u; *p; p++) if (*p == '\\') *p = '/';
    n = (DWORD)strlen(u);
    while (n > 3 && u[n - 1] == '/') u[--n] = 0;
    if (resolved) { snprintf(resolved, MAX_PATH, "%s", u); free(u); return resolved; }
    return u;
}

/* ---- processes, host, locks ---- */
#define getpid() ((long)GetCurrentProcessId())
#define kill smw_kill
#define gethostname smw_gethostname
#define flock smw_flock
#define LOCK_EX 2
#define LOCK_NB 4
#define LOCK_UN 8
#ifndef ESRCH
#define ESRCH 3
#endif
SMW_API int smw_kill(long pid, int sig) { /* sig 0 only: does the process run? */
    HANDLE h = OpenProcess(PROCESS_QUERY_LIMITED_INFORMATION, FALSE, (DWORD)pid);
    DWORD code = 0;
    (void)sig;
    if (!h) { DWORD e = GetLastError(); errno = e == ERROR_INVALID_PARAMETER ? ESRCH : EPERM; return -1; }
    if (GetExitCodeProcess(h, &code) && code != STILL_ACTIVE) { CloseHandle(h); errno = ESRCH; return -1; }
    CloseHandle(h);
    return 0;
}
SMW_API int smw_gethostname(char *buf, size_t cap) {
    DWORD n = (DWORD)cap;
    return GetComputerNameA(buf, &n) ? 0 : -1;
}
SMW_API int smw_flock(int fd, int op) {
    HANDLE h = (HANDLE)_get_osfhandle(fd);
    OVERLAPPED ov;
    memset(&ov, 0, sizeof ov);
    ov.Offset = 0;
    ov.OffsetHigh = 0x7fffffffu; /* one byte far past any end: locks nobody out of reading or appending */
    if (h == INVALID_HANDLE_VALUE) { errno = EBADF; return -1; }
    if (op & LOCK_UN) return UnlockFileEx(h, 0, 1, 0, &ov) ? 0 : smw_fail();
    if (LockFileEx(h, LOCKFILE_EXCLUSIVE_LOCK | ((op & LOCK_NB) ? LOCKFILE_FAIL_IMMEDIATELY : 0), 0, 1, 0, &ov)) return 0;
    errno = EWOULDBLOCK;
    return -1;
}
#define pread smw_pread
SMW_API long smw_pread(int fd, void *buf, size_t n, long long off) {
    if (_lseeki64(fd, off, SEEK_SET) < 0) return -1;
    return _read(fd, buf, (unsigned)n);
}

/* ---- mmap (read-only, whole file) ---- */
#define PROT_READ 1
#define MAP_PRIVATE 2
#define MAP_FAILED ((void *)-1)
#define mmap smw_mmap
#define munmap smw_munmap
SMW_API void *smw_mmap(void *addr, size_t n, int prot, int flags, int fd, long long off) {
    HANDLE h = (HANDLE)_get_osfhandle(fd), m;
    void *p;
    (void)addr; (void)prot; (void)flags; (void)off;
    if (h == INVALID_HANDLE_VALUE || !n) return MAP_FAILED;
    m = CreateFileMappingW(h, NULL, PAGE_READONLY, 0, 0, NULL);
    if (!m) return MAP_FAILED;
    p = MapViewOfFile(m, FILE_MAP_READ, 0, 0, n);
    CloseHandle(m); /* the view keeps the mapping */
    return p ? p : MAP_FAILED;
}
SMW_API int smw_munmap(void *p, size_t n) { (void)n; return UnmapViewOfFile(p) ? 0 : -1; }

/* ---- getline, statvfs, getrusage ---- */
#define getline smw_getline
SMW_API long smw_getline(char **line, size_t *cap, FILE *f) {
    size_t n = 0;
    int c;
    if (!*line || *cap < 2) {
        char *p = (char *)realloc(*line, 128);
        if (!p) { errno = ENOMEM; return -1; }
        *line = p;
        *cap = 128;
    }
    while ((c = getc(f)) != EOF) {
        if (n + 2 > *cap) {
            char *p = (char *)realloc(*line, *cap * 2);
            if (!p) { errno = ENOMEM; return -1; }
            *line = p;
            *cap *= 2;
        }
        (*line)[n++] = (char)c;
        if (c == '\n') break;
    }
    (*line)[n] = 0;
    return n ? (long)n : -1;
}
struct smw_statvfs { unsigned long long f_bavail, f_frsize; };
#define statvfs smw_statvfs
SMW_API int smw_statvfs(const char *path, struct smw_statvfs *v) {
    wchar_t *w = smw_wide(path);
    ULARGE_INTEGER avail;
    BOOL ok;
    if (!w) return -1;
    ok = GetDiskFreeSpaceExW(w, &avail, NULL, NULL);
    free(w);
    if (!ok) return smw_fail();
    v->f_bavail = avail.QuadPart;
    v->f_frsize = 1;
    return 0;
}
struct smw_rusage { long ru_maxrss; };
#define rusage smw_rusage
#define getrusage smw_getrusage
#define RUSAGE_SELF 0
SMW_API int smw_getrusage(int who, struct smw_rusage *ru) {
    PROCESS_MEMORY_COUNTERS pm;
    (void)who;
    memset(&pm, 0, sizeof pm);
    if (!GetProcessMemoryInfo(GetCurrentProcess(), &pm, sizeof pm)) return -1;
    ru->ru_maxrss = (long)(pm.PeakWorkingSetSize / 1024u);
    return 0;
}

/* ---- getenv: UTF-8 (the environment is UTF-16 on Windows); each name's value kept for the process ---- */
#define getenv smw_getenv
SMW_API char *smw_getenv(const char *name) {
    static struct { char *name, *value; } cache[32];
    static int n;
    wchar_t *w = smw_wide(name), *v;
    char *u = NULL;
    int i;
    if (!w) return NULL;
    v = _wgetenv(w);
    free(w);
    if (!v) return NULL;
    smw_locked(1);
    for (i = 0; i < n; i++)
        if (!strcmp(cache[i].name, name)) break;
    if (i < n) u = cache[i].value;
    else if (n < 32 && (u = smw_utf8(v)) != NULL && (cache[n].name = _strdup(name)) != NULL) {
        char *c;
        if (!strstr(name, "TOKEN")) /* a folder (LOCALAPPDATA ...) splits at '/' as the arguments do; a secret stays as it is */
            for (c = u; *c; c++) if (*c == '\\') *c = '/';
        cache[n].value = u;
        n++;
    }
    smw_locked(0);
    return u;
}

/* ---- the command line in UTF-8 ---- */
SMW_API void smw_args(int *argc, char ***argv) {
    int n = 0, i;
    wchar_t **wv = CommandLineToArgvW(GetCommandLineW(), &n);
    char **v;
    SetConsoleOutputCP(CP_UTF8);
    if (!wv || n < 1 || !(v = (char **)calloc((size_t)n + 1, sizeof *v))) return;
    for (i = 0; i < n; i++) {
        char *c;
        if (!(v[i] = smw_utf8(wv[i]))) return;
        for (c = v[i]; *c; c++) if (*c == '\\') *c = '/'; /* C:\maps\x.png -> C:/maps/x.png: the CLI splits paths at '/' */
    }
    LocalFree(wv);
    *argc = n;
    *argv = v;
}

/* ---- a program with pipes (cli_spawn_piped): CreateProcessW, the command line quoted as CommandLineToArgvW
   splits it; the program is looked up in PATH as CreateProcessW does (".exe" added) ---- */
SMW_API int smw_quote(wchar_t *dst, const wchar_t *a) { /* writes (when dst) the quoted argument; its length */
    int n = 0, bs = 0;
    const wchar_t *p;
#define SMW_PUT(c) do { if (dst) dst[n] = (c); n++; } while (0)
    if (*a && !wcspbrk(a, L" \t\n\v\"")) { for (p = a; *p; p++) SMW_PUT(*p); return n; }
    SMW_PUT(L'"');
    for (p = a;; p++) {
        if (*p == L'\\') { bs++; continue; }
        if (!*p || *p == L'"') {
            int k, twice = *p ? 2 * bs + 1 : 2 * bs; /* backslashes before a quote (ours or theirs) doubled */
            for (k = 0; k < twice; k++) SMW_PUT(L'\\');
            if (!*p) break;
            SMW_PUT(L'"');
        } else {
            for (; bs; bs--) SMW_PUT(L'\\');
            SMW_PUT(*p);
        }
        bs = 0;
    }
    SMW_PUT(L'"');
#undef SMW_PUT
    return n;
}
SMW_API int smw_spawn_piped(char **argv, const char *input, char *out, size_t cap) {
    SECURITY_ATTRIBUTES sa;
    STARTUPINFOW si;
    PROCESS_INFORMATION pi;
    HANDLE in_r = NULL, in_w = NULL, out_r = NULL, out_w = NULL, err = NULL;
    wchar_t **wa, *cmd;
    size_t n = 0, len = 0;
    int i, argc = 0;
    DWORD code = 0;
    BOOL ok;
    for (argc = 0; argv[argc]; argc++) {}
    if (!(wa = (wchar_t **)calloc((size_t)argc + 1, sizeof *wa))) { errno = ENOMEM; return -1; }
    for (i = 0; i < argc; i++) {
        if (!(wa[i] = smw_wide(argv[i]))) { while (i--) free(wa[i]); free(wa); return -1; }
        len += (size_t)smw_quote(NULL, wa[i]) + 1;
    }
    if (!(cmd = (wchar_t *)malloc((len + 1) * sizeof *cmd))) { for (i = 0; i < argc; i++) free(wa[i]); free(wa); errno = ENOMEM; return -1; }
    for (i = 0, len = 0; i < argc; i++) {
        if (i) cmd[len++] = L' ';
        len += (size_t)smw_quote(cmd + len, wa[i]);
    }
    cmd[len] = 0;
    for (i = 0; i < argc; i++) free(wa[i]);
    free(wa);
    memset(&sa, 0, sizeof sa);
    sa.nLength = sizeof sa;
    sa.bInheritHandle = TRUE;
    if (!CreatePipe(&in_r, &in_w, &sa, 0) || !CreatePipe(&out_r, &out_w, &sa, 0)) {
        smw_fail();
        if (in_r) { CloseHandle(in_r); CloseHandle(in_w); }
        free(cmd);
        return -1;
    }
    SetHandleInformation(in_w, HANDLE_FLAG_INHERIT, 0); /* our ends stay ours */
    SetHandleInformation(out_r, HANDLE_FLAG_INHERIT, 0);
    if (!DuplicateHandle(GetCurrentProcess(), GetStdHandle(STD_ERROR_HANDLE), GetCurrentProcess(), &err, 0, TRUE, DUPLICATE_SAME_ACCESS)) err = NULL;
    memset(&si, 0, sizeof si);
    si.cb = sizeof si;
    si.dwFlags = STARTF_USESTDHANDLES;
    si.hStdInput = in_r;
    si.hStdOutput = out_w;
    si.hStdError = err;
    fflush(stdout);
    fflush(stderr);
    ok = CreateProcessW(NULL, cmd, NULL, NULL, TRUE, 0, NULL, NULL, &si, &pi);
    if (!ok) smw_fail();
    free(cmd);
    CloseHandle(in_r);
    CloseHandle(out_w);
    if (err) CloseHandle(err);
    if (!ok) { i = errno; CloseHandle(in_w); CloseHandle(out_r); errno = i; return -1; }
    CloseHandle(pi.hThread);
    if (input && *input) {
        size_t l = strlen(input), w = 0;
        while (w < l) {
            DWORD k = 0;
            if (!WriteFile(in_w, input + w, (DWORD)(l - w), &k, NULL) || !k) break; /* it exited without reading: fine */
            w += k;
        }
    }
    CloseHandle(in_w);
    for (;;) {
        char tmp[4096];
        DWORD k = 0;
        if (!ReadFile(out_r, tmp, sizeof tmp, &k, NULL) || !k) break;
        if (out && n + 1 < cap) {
            size_t c = (size_t)k < cap - 1 - n ? (size_t)k : cap - 1 - n;
            memcpy(out + n, tmp, c);
            n += c;
        }
    }
    if (out && cap) out[n] = 0;
    CloseHandle(out_r);
    WaitForSingleObject(pi.hProcess, INFINITE);
    GetExitCodeProcess(pi.hProcess, &code);
    CloseHandle(pi.hProcess);
    return (int)code;
}

#endif
