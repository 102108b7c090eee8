#define _GNU_SOURCE /* getrandom, O_NOFOLLOW, O_CLOEXEC */
#include "rad_fs.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "rad_log.h"

/* ---- the signal guard ---- */

/* The termination signals, and the faults (a crash removes its temporaries
 * too: a SIGSEGV in the form-factor kernel once left a 0-byte one). The
 * handler re-raises with the default action, so a fault still dumps core. */
static const int guarded_signals[] = {SIGTERM, SIGINT,    SIGHUP,  SIGQUIT, SIGUSR1, SIGUSR2, SIGALRM,
                                      SIGPIPE, SIGXCPU,   SIGXFSZ, SIGVTALRM, SIGPROF, SIGSEGV, SIGBUS,
                                      SIGFPE,  SIGILL,    SIGABRT};
#define GUARDED_COUNT (sizeof guarded_signals / sizeof guarded_signals[0])
static char g_guard_name[RAD_FS_GUARD_SLOTS][4096];
/* A slot's name counts only while its flag is set: the name is written
 * before the flag goes up and the flag goes down before the name changes,
 * so a handler on any thread sees whole names only. */
static volatile sig_atomic_t g_guard_valid[RAD_FS_GUARD_SLOTS];
static int g_guard_count;
static struct sigaction g_guard_previous[GUARDED_COUNT];
static int g_guard_installed[GUARDED_COUNT];

/* The timer signals a process may use as ticks (a profiler, libFuzzer's
 * -timeout watchdog): where they already have a handler they do not end
 * the process, so the guard leaves them to it. Taking one over killed a
 * fuzz run whose watchdog ticked while a file was being written. */
static int guard_takes(int sig)
{
    if (sig != SIGALRM && sig != SIGVTALRM && sig != SIGPROF) return 1;
    struct sigaction current;
    if (sigaction(sig, NULL, &current) != 0) return 1;
    return !(current.sa_flags & SA_SIGINFO) && current.sa_handler == SIG_DFL;
}
static pthread_mutex_t g_guard_lock = PTHREAD_MUTEX_INITIALIZER;

/* Async-signal-safe: unlink and re-raise only. */
static void remove_guarded_and_die(int sig)
{
    for (int k = 0; k < RAD_FS_GUARD_SLOTS; k++)
        if (g_guard_valid[k]) unlink(g_guard_name[k]);
    signal(sig, SIG_DFL);
    raise(sig); /* blocked until the handler returns, then the default action */
}

static int guard_find(const char *path)
{
    for (int k = 0; k < RAD_FS_GUARD_SLOTS; k++)
        if (g_guard_valid[k] && !strcmp(g_guard_name[k], path)) return k;
    return -1;
}

rad_status rad_fs_guard(const char *temp_path)
{
    if (strlen(temp_path) >= sizeof g_guard_name[0]) {
        rad_error("%s: name too long to guard", temp_path);
        return RAD_ERR_USAGE;
    }
    pthread_mutex_lock(&g_guard_lock);
    int slot = guard_find(temp_path);
    rad_status status = RAD_OK;
    if (slot < 0) {
        for (slot = 0; slot < RAD_FS_GUARD_SLOTS && g_guard_valid[slot]; slot++) {}
        if (slot == RAD_FS_GUARD_SLOTS) {
            rad_error("%s: more than %d temporary files at once", temp_path, RAD_FS_GUARD_SLOTS);
            status = RAD_ERR_NOMEM;
        } else {
            memcpy(g_guard_name[slot], temp_path, strlen(temp_path) + 1);
            __atomic_thread_fence(__ATOMIC_SEQ_CST);
            g_guard_valid[slot] = 1;
            if (g_guard_count++ == 0) {
                struct sigaction sa;
                memset(&sa, 0, sizeof sa);
                sa.sa_handler = remove_guarded_and_die;
                sigfillset(&sa.sa_mask);
                for (size_t k = 0; k < GUARDED_COUNT; k++) {
                    g_guard_installed[k] = guard_takes(guarded_signals[k]);
                    if (g_guard_installed[k]) sigaction(guarded_signals[k], &sa, &g_guard_previous[k]);
                }
            }
        }
    }
    pthread_mutex_unlock(&g_guard_lock);
    return status;
}

void rad_fs_unguard(const char *temp_path)
{
    pthread_mutex_lock(&g_guard_lock);
    int slot = guard_find(temp_path);
    if (slot >= 0) {
        g_guard_valid[slot] = 0;
        __atomic_thread_fence(__ATOMIC_SEQ_CST);
        if (--g_guard_count == 0)
            for (size_t k = 0; k < GUARDED_COUNT; k++)
                if (g_guard_installed[k]) sigaction(guarded_signals[k], &g_guard_previous[k], NULL);
    }
    pthread_mutex_unlock(&g_guard_lock);
}

/* ---- temporaries ---- */

static uint64_t random_suffix(void)
{
    uint64_t r = 0;
    if (getrandom(&r, sizeof r, GRND_NONBLOCK) == (ssize_t)sizeof r) return r;
    struct timespec t;
    clock_gettime(CLOCK_REALTIME, &t);
    static uint64_t counter;
    r = (uint64_t)t.tv_nsec ^ ((uint64_t)t.tv_sec << 30) ^ ((uint64_t)getpid() << 40) ^ ++counter;
    r ^= r >> 31;
    r *= 0x9E3779B97F4A7C15ull;
    return r ^ (r >> 29);
}

static int is_char_device(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISCHR(st.st_mode);
}

rad_status rad_fs_temp_create(const char *final_path, char *out, size_t out_size)
{
    if (is_char_device(final_path)) { /* written in place */
        if (strlen(final_path) >= out_size) {
            rad_error("%s: output path too long", final_path);
            return RAD_ERR_USAGE;
        }
        memcpy(out, final_path, strlen(final_path) + 1);
        return RAD_OK;
    }
    /* The guarded signals wait while the temporary is created and guarded:
     * one that came in between killed the process with the file left. */
    sigset_t guarded, previous;
    sigemptyset(&guarded);
    for (size_t k = 0; k < GUARDED_COUNT; k++) sigaddset(&guarded, guarded_signals[k]);
    pthread_sigmask(SIG_BLOCK, &guarded, &previous);
    rad_status status = RAD_ERR_IO;
    int made = 0;
    for (int attempt = 0; attempt < 16 && !made; attempt++) {
        int n = snprintf(out, out_size, "%s.tmp-%016llx", final_path, (unsigned long long)random_suffix());
        if (n < 0 || (size_t)n >= out_size) {
            rad_error("%s: output path too long", final_path);
            status = RAD_ERR_USAGE;
            break;
        }
        int fd = open(out, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd < 0 && errno == EEXIST) continue; /* planted or unlucky: another name */
        made = 1;
        if (fd < 0) {
            rad_error("%s: cannot write: creating its temporary %s: %s", final_path, out, strerror(errno));
            status = RAD_ERR_IO;
            break;
        }
        close(fd);
        status = rad_fs_guard(out);
        if (status != RAD_OK) unlink(out);
    }
    pthread_sigmask(SIG_SETMASK, &previous, NULL);
    if (!made && status == RAD_ERR_IO) rad_error("%s: cannot create a temporary beside it (16 names taken)", final_path);
    return status;
}

FILE *rad_fs_temp_open(const char *temp)
{
    int fd = open(temp, O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) return NULL;
    FILE *f = fdopen(fd, "wb");
    if (!f) close(fd);
    return f;
}

rad_status rad_fs_commit(const char *temp_path, const char *final_path)
{
    if (!strcmp(temp_path, final_path)) return RAD_OK; /* a device, written in place */
    if (rename(temp_path, final_path) != 0) {
        rad_error("%s: cannot rename %s over it: %s", final_path, temp_path, strerror(errno));
        rad_fs_discard(temp_path);
        return RAD_ERR_IO;
    }
    rad_fs_unguard(temp_path);
    return RAD_OK;
}

void rad_fs_discard(const char *temp_path)
{
    pthread_mutex_lock(&g_guard_lock);
    int ours = guard_find(temp_path) >= 0;
    pthread_mutex_unlock(&g_guard_lock);
    if (!ours) return; /* never a device, never a name we did not make */
    remove(temp_path);
    rad_fs_unguard(temp_path);
}

rad_status rad_fs_create_temp(const char *final_path, char *temp, size_t temp_size, FILE **out_file)
{
    rad_status status = rad_fs_temp_create(final_path, temp, temp_size);
    if (status != RAD_OK) return status;
    FILE *f = rad_fs_temp_open(temp);
    if (!f) {
        rad_error("%s: cannot open: %s", temp, strerror(errno));
        rad_fs_discard(temp);
        return RAD_ERR_IO;
    }
    *out_file = f;
    return RAD_OK;
}

rad_status rad_fs_close_commit(FILE *f, const char *temp, const char *final_path)
{
    int failed = ferror(f);
    if (fclose(f) != 0) failed = 1;
    if (failed) {
        rad_error("%s: write failed: %s", temp, strerror(errno));
        rad_fs_discard(temp);
        return RAD_ERR_IO;
    }
    return rad_fs_commit(temp, final_path);
}

/* ---- outputs and roles ---- */

static const char *kind_name(mode_t mode)
{
    return S_ISDIR(mode) ? "a directory" : S_ISFIFO(mode) ? "a FIFO" : S_ISSOCK(mode) ? "a socket"
         : S_ISBLK(mode) ? "a block device" : "not a regular file";
}

rad_status rad_fs_check_output(const char *option, const char *path)
{
    if (!path) return RAD_OK;
    if (!*path) {
        rad_error("%s: empty file name", option);
        return RAD_ERR_USAGE;
    }
    struct stat st;
    int exists = stat(path, &st) == 0;
    if (exists && S_ISCHR(st.st_mode)) return RAD_OK; /* written in place */
    if (exists && !S_ISREG(st.st_mode)) {
        rad_error("%s: %s: is %s; outputs are regular files, new ones, or character devices such as /dev/null "
                  "(docs/reliability.md)",
                  option, path, kind_name(st.st_mode));
        return RAD_ERR_USAGE;
    }
    /* A new or regular file is written as a temporary beside it and renamed:
     * its folder must exist and take new files. Checked now, before any
     * work, so that a late output cannot fail after an earlier one has
     * replaced its old file. */
    char dir[4096];
    const char *slash = strrchr(path, '/');
    if (!slash) {
        strcpy(dir, ".");
    } else if ((size_t)(slash - path) >= sizeof dir) {
        rad_error("%s: %s: path too long", option, path);
        return RAD_ERR_USAGE;
    } else {
        size_t len = slash == path ? 1 : (size_t)(slash - path);
        memcpy(dir, path, len);
        dir[len] = 0;
    }
    if (stat(dir, &st) != 0) {
        rad_error("%s: %s: cannot write: folder %s: %s", option, path, dir, strerror(errno));
        return RAD_ERR_USAGE;
    }
    if (!S_ISDIR(st.st_mode)) {
        rad_error("%s: %s: cannot write: %s is not a folder", option, path, dir);
        return RAD_ERR_USAGE;
    }
    if (access(dir, W_OK | X_OK) != 0) {
        rad_error("%s: %s: cannot write into folder %s: %s", option, path, dir, strerror(errno));
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* A file's identity: device and inode when it exists; else its folder's
 * and its last name component. */
typedef struct file_identity {
    dev_t dev;
    ino_t ino;
    int exists, is_char;
    char name[256];
} file_identity;

static int identify(const char *path, file_identity *id)
{
    memset(id, 0, sizeof *id);
    struct stat st;
    if (stat(path, &st) == 0) {
        id->exists = 1;
        id->dev = st.st_dev;
        id->ino = st.st_ino;
        id->is_char = S_ISCHR(st.st_mode);
        return 1;
    }
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    char dir[4096];
    if (slash) {
        size_t len = (size_t)(slash - path);
        if (len >= sizeof dir) return 0;
        memcpy(dir, path, len);
        dir[len] = 0;
        if (len == 0) strcpy(dir, "/");
    } else {
        strcpy(dir, ".");
    }
    if (strlen(base) >= sizeof id->name || stat(dir, &st) != 0) return 0;
    id->dev = st.st_dev;
    id->ino = st.st_ino;
    memcpy(id->name, base, strlen(base) + 1);
    return 1;
}

rad_status rad_fs_check_roles(const rad_fs_role *roles, size_t count)
{
    for (size_t a = 0; a < count; a++) {
        if (!roles[a].path) continue;
        file_identity ia;
        if (!identify(roles[a].path, &ia)) continue;
        for (size_t b = a + 1; b < count; b++) {
            if (!roles[b].path || !(roles[a].output || roles[b].output)) continue;
            file_identity ib;
            if (!identify(roles[b].path, &ib)) continue;
            int same = ia.exists == ib.exists && ia.dev == ib.dev && ia.ino == ib.ino &&
                       (ia.exists || !strcmp(ia.name, ib.name));
            if (!same || (ia.is_char && roles[a].output && roles[b].output)) continue;
            rad_error("%s and %s name the same file (%s)%s", roles[a].option, roles[b].option, roles[b].path,
                      roles[a].output && roles[b].output ? ": one would overwrite the other"
                                                         : ": the output would overwrite the input");
            return RAD_ERR_USAGE;
        }
    }
    return RAD_OK;
}

FILE *rad_fs_open_input(const char *path)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        rad_error("%s: cannot open: %s", path, strerror(errno));
        return NULL;
    }
    struct stat st;
    if (fstat(fd, &st) != 0) {
        rad_error("%s: cannot examine: %s", path, strerror(errno));
        close(fd);
        return NULL;
    }
    if (!S_ISREG(st.st_mode)) {
        rad_error("%s: is %s; inputs are regular files", path,
                  S_ISCHR(st.st_mode) ? "a character device" : kind_name(st.st_mode));
        close(fd);
        return NULL;
    }
    int flags = fcntl(fd, F_GETFL);
    if (flags >= 0) fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        rad_error("%s: cannot open: %s", path, strerror(errno));
        close(fd);
    }
    return f;
}

rad_status rad_fs_read_all(const char *path, char **out_data, size_t *out_size)
{
    rad_status status = RAD_ERR_IO;
    char *data = NULL;
    *out_data = NULL;
    *out_size = 0;
    FILE *f = rad_fs_open_input(path);
    if (!f) return RAD_ERR_IO;
    struct stat st;
    if (fstat(fileno(f), &st) == 0 && (uint64_t)st.st_size > RAD_FS_READ_MAX) {
        rad_error("%s: %llu bytes; files of at most %zu bytes are read", path, (unsigned long long)st.st_size,
                  (size_t)RAD_FS_READ_MAX);
        fclose(f);
        return RAD_ERR_IO;
    }
    size_t cap = 1 << 16, size = 0;
    data = malloc(cap + 1);
    if (!data) { status = RAD_ERR_NOMEM; goto done; }
    for (;;) {
        size_t got = fread(data + size, 1, cap - size, f);
        size += got;
        if (size < cap) break;
        if (cap >= RAD_FS_READ_MAX) { /* grew while being read */
            rad_error("%s: more than %zu bytes; files of at most that are read", path, (size_t)RAD_FS_READ_MAX);
            goto done;
        }
        char *grown = realloc(data, 2 * cap + 1);
        if (!grown) { status = RAD_ERR_NOMEM; goto done; }
        data = grown;
        cap *= 2;
    }
    if (ferror(f)) {
        rad_error("%s: read error: %s", path, strerror(errno));
        goto done;
    }
    data[size] = 0;
    *out_data = data;
    *out_size = size;
    data = NULL;
    status = RAD_OK;
done:
    if (status == RAD_ERR_NOMEM) rad_error("%s: out of memory reading the file", path);
    free(data);
    fclose(f);
    return status;
}
