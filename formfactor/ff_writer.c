/* ff_writer.c - background writes of one rank's byte ranges (ff_writer.h):
 * POSIX files and threads, no MPI. */
#define _GNU_SOURCE /* pwrite, O_NOFOLLOW, MADV_POPULATE_WRITE */
#include "ff_writer.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/vfs.h>
#include <unistd.h>

#include "rad_clock.h"
#include "rad_log.h"

#if defined(__linux__) && !defined(MADV_POPULATE_WRITE)
#define MADV_POPULATE_WRITE 23 /* Linux 5.14; older C libraries lack the name */
#endif

/* A write is split among the threads in slices of at least this much:
 * smaller ones cost more in mapping and waking threads than they gain. */
#define FF_WRITER_SLICE_MIN ((uint64_t)4 << 20)
/* A writer thread's stack. */
#define FF_WRITER_STACK_BYTES ((size_t)256 << 10)
/* errno-like code for a write that made no progress (pwrite returned 0). */
#define FF_WRITER_NO_PROGRESS (-1)
/* ... and for pages the file system could not give a mapping (full). */
#define FF_WRITER_NO_PAGES (-2)

typedef struct ff_writer_thread {
    struct ff_writer *writer;
    int index;
    pthread_t id;
} ff_writer_thread;

struct ff_writer {
    int fd;
    char path[4096];
    atomic_int map;        /* 1: writes go through a shared mapping; 0 once it is refused */
    uint64_t grown;        /* the length this writer last gave the file (mapped writes) */
    uint64_t page;         /* bytes */
    int threads_wanted;
    int threads;           /* running */
    ff_writer_thread thread[FF_WRITER_MAX_THREADS];
    pthread_mutex_t lock;
    pthread_cond_t work, idle;
    /* The write in flight, under `lock`. */
    const unsigned char *data;
    uint64_t offset, bytes;
    uint64_t job;          /* writes submitted so far: a thread takes each number once */
    int pending;           /* threads not done with it */
    int stop;
    double job_start;
    /* Results, under `lock`. */
    int error;             /* the first failure: an errno, or FF_WRITER_NO_* */
    uint64_t error_offset;
    int reported;          /* logged (by the main thread) */
    double seconds;
    uint64_t written;
};

static uint64_t min_u64(uint64_t a, uint64_t b) { return a < b ? a : b; }

/* pwrite all of it, resuming after short writes: 0, or an error code. */
static int write_plain(int fd, uint64_t offset, const unsigned char *data, uint64_t bytes)
{
    while (bytes > 0) {
        size_t piece = (size_t)min_u64(bytes, (uint64_t)1 << 30);
        ssize_t n = pwrite(fd, data, piece, (off_t)offset);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) return errno ? errno : EIO;
        if (n == 0) return FF_WRITER_NO_PROGRESS;
        data += n;
        offset += (uint64_t)n;
        bytes -= (uint64_t)n;
    }
    return 0;
}

/* Through a shared mapping of the pages that hold the range: the pages are
 * made present and writable first (MADV_POPULATE_WRITE), which reports a
 * full file system as an error instead of a SIGBUS during the copy.
 * Returns 0, an error code, or 1 where the mapping cannot be used (the
 * caller writes with pwrite from then on). */
static int write_mapped(ff_writer *w, uint64_t offset, const unsigned char *data, uint64_t bytes)
{
#ifdef __linux__
    uint64_t first = offset / w->page * w->page, length = offset + bytes - first;
    void *map = mmap(NULL, (size_t)length, PROT_READ | PROT_WRITE, MAP_SHARED, w->fd, (off_t)first);
    if (map == MAP_FAILED) return 1; /* no address space (ulimit -v), or a file that cannot be mapped */
    int result = 0;
    if (madvise(map, (size_t)length, MADV_POPULATE_WRITE) != 0) {
        if (errno == EFAULT || errno == EHWPOISON)
            result = FF_WRITER_NO_PAGES; /* where the copy would have met a SIGBUS */
        else
            result = 1; /* EINVAL: a kernel before 5.14; ENOMEM: pwrite says what is short */
    }
    if (result == 0) memcpy((unsigned char *)map + (offset - first), data, (size_t)bytes);
    munmap(map, (size_t)length);
    return result;
#else
    (void)w, (void)offset, (void)data, (void)bytes;
    return 1;
#endif
}

static int write_range(ff_writer *w, uint64_t offset, const unsigned char *data, uint64_t bytes)
{
    if (atomic_load(&w->map)) {
        int result = write_mapped(w, offset, data, bytes);
        if (result != 1) return result;
        atomic_store(&w->map, 0);
    }
    return write_plain(w->fd, offset, data, bytes);
}

/* Thread `index`'s slice of the write in flight: [*begin, *end) of it. */
static void slice_of(const ff_writer *w, int index, uint64_t *begin, uint64_t *end)
{
    uint64_t slices = (w->bytes + FF_WRITER_SLICE_MIN - 1) / FF_WRITER_SLICE_MIN;
    if (slices > (uint64_t)w->threads) slices = (uint64_t)w->threads;
    if (slices == 0) slices = 1;
    uint64_t size = (w->bytes + slices - 1) / slices;
    size = (size + w->page - 1) / w->page * w->page; /* whole pages: no page is mapped by two slices */
    *begin = min_u64((uint64_t)index * size, w->bytes);
    *end = min_u64(*begin + size, w->bytes);
}

static void finish_slice(ff_writer *w, int error, uint64_t at, uint64_t bytes)
{
    if (error && !w->error) {
        w->error = error;
        w->error_offset = at;
    }
    if (!error) w->written += bytes;
    if (--w->pending == 0) {
        w->seconds += rad_clock_seconds() - w->job_start;
        pthread_cond_broadcast(&w->idle);
    }
}

static void *writer_thread(void *arg)
{
    ff_writer_thread *t = arg;
    ff_writer *w = t->writer;
    uint64_t seen = 0;
    pthread_mutex_lock(&w->lock);
    for (;;) {
        while (w->job == seen && !w->stop) pthread_cond_wait(&w->work, &w->lock);
        if (w->stop) break;
        seen = w->job;
        uint64_t begin, end;
        slice_of(w, t->index, &begin, &end);
        const unsigned char *data = w->data;
        uint64_t offset = w->offset;
        int skip = w->error != 0;
        pthread_mutex_unlock(&w->lock);
        int error = end > begin && !skip ? write_range(w, offset + begin, data + begin, end - begin) : 0;
        pthread_mutex_lock(&w->lock);
        finish_slice(w, error, offset + begin, end - begin);
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}

/* Linux file systems that are local to one node: a mapping there is
 * coherent with every other process's writes to the same pages. (A
 * network file system writes back whole pages: two nodes' mapped writes
 * to one page would undo each other.) */
static int local_file_system(int fd)
{
#ifdef __linux__
    struct statfs fs;
    if (fstatfs(fd, &fs) != 0) return 0;
    switch ((unsigned long)fs.f_type) {
    case 0x01021994UL: /* tmpfs */
    case 0xEF53UL:     /* ext2/3/4 */
    case 0x58465342UL: /* xfs */
    case 0x9123683EUL: /* btrfs */
    case 0x794C7630UL: /* overlayfs (a container's disk: its upper layer is one of those) */
        return 1;
    default:
        return 0;
    }
#else
    (void)fd;
    return 0;
#endif
}

rad_status ff_writer_open(const char *path, const ff_writer_options *options, ff_writer **out_writer)
{
    ff_writer *w = calloc(1, sizeof *w);
    if (!w) {
        rad_error("%s: out of memory", path);
        return RAD_ERR_NOMEM;
    }
    snprintf(w->path, sizeof w->path, "%s", path);
    w->threads_wanted = options && options->threads > 0 ? options->threads : 1;
    if (w->threads_wanted > FF_WRITER_MAX_THREADS) w->threads_wanted = FF_WRITER_MAX_THREADS;
    long page = sysconf(_SC_PAGESIZE);
    w->page = page > 0 ? (uint64_t)page : 4096;
    /* The file exists (rad_fs_temp_create made it, empty, or it is a
     * device written in place): opened, never created, no symlink followed. */
    w->fd = open(path, O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
    if (w->fd < 0) {
        rad_error("%s: cannot open: %s", path, strerror(errno));
        free(w);
        return RAD_ERR_IO;
    }
    struct stat st;
    int regular = fstat(w->fd, &st) == 0 && S_ISREG(st.st_mode);
    /* A mapping needs the file open for reading too (PROT_WRITE on a
     * shared mapping requires O_RDWR): a second descriptor, where allowed. */
    int mapped = regular && (!options || options->method != FF_WRITE_PWRITE) && local_file_system(w->fd);
    if (mapped) {
        int rw = open(path, O_RDWR | O_NOFOLLOW | O_CLOEXEC);
        if (rw >= 0) {
            close(w->fd);
            w->fd = rw;
        } else {
            mapped = 0;
        }
    }
    atomic_init(&w->map, mapped);
    pthread_mutex_init(&w->lock, NULL);
    pthread_cond_init(&w->work, NULL);
    pthread_cond_init(&w->idle, NULL);
    *out_writer = w;
    return RAD_OK;
}

/* Starts the threads on the first write; where none can start, writes
 * happen in submit itself. */
static void start_threads(ff_writer *w)
{
    pthread_attr_t attr;
    int have_attr = pthread_attr_init(&attr) == 0;
    /* Small stacks: the threads only copy; the default (the stack rlimit,
     * 8 MiB) would count against an address-space limit four times. */
    if (have_attr) pthread_attr_setstacksize(&attr, FF_WRITER_STACK_BYTES);
    for (int k = 0; k < w->threads_wanted; k++) {
        w->thread[k] = (ff_writer_thread){.writer = w, .index = k};
        if (pthread_create(&w->thread[k].id, have_attr ? &attr : NULL, writer_thread, &w->thread[k]) != 0) break;
        w->threads = k + 1;
    }
    if (have_attr) pthread_attr_destroy(&attr);
    w->threads_wanted = 0;
}

/* The first failure, logged once; under no lock (main thread). */
static rad_status report(ff_writer *w, int error, uint64_t at)
{
    if (!error) return RAD_OK;
    if (!w->reported) {
        const char *why = error == FF_WRITER_NO_PROGRESS ? "no progress (disk full?)"
                          : error == FF_WRITER_NO_PAGES ? "No space left on device (no pages for the mapping)"
                                                        : strerror(error);
        rad_error("%s: write failed at byte %llu: %s", w->path, (unsigned long long)at, why);
        w->reported = 1;
    }
    return RAD_ERR_IO;
}

rad_status ff_writer_wait(ff_writer *w)
{
    pthread_mutex_lock(&w->lock);
    while (w->pending > 0) pthread_cond_wait(&w->idle, &w->lock);
    int error = w->error;
    uint64_t at = w->error_offset;
    pthread_mutex_unlock(&w->lock);
    return report(w, error, at);
}

rad_status ff_writer_submit(ff_writer *w, uint64_t offset, const void *data, uint64_t bytes, uint64_t file_end)
{
    rad_status status = ff_writer_wait(w);
    if (status != RAD_OK) return status;
    /* Mapped pages must lie inside the file. Every rank grows it to the
     * same length in a round, and rounds only lengthen it (ff_writer.h),
     * so no rank cuts off another's bytes. */
    if (atomic_load(&w->map) && file_end > w->grown) {
        if (ftruncate(w->fd, (off_t)file_end) != 0) {
            pthread_mutex_lock(&w->lock);
            if (!w->error) w->error = errno, w->error_offset = file_end;
            pthread_mutex_unlock(&w->lock);
            return ff_writer_wait(w);
        }
        w->grown = file_end;
    }
    if (bytes == 0) return RAD_OK;
    if (w->threads_wanted > 0) start_threads(w);
    pthread_mutex_lock(&w->lock);
    if (w->threads == 0) { /* no thread: written here */
        double t0 = rad_clock_seconds();
        pthread_mutex_unlock(&w->lock);
        int error = write_range(w, offset, data, bytes);
        pthread_mutex_lock(&w->lock);
        w->pending = 1;
        w->job_start = t0;
        finish_slice(w, error, offset, bytes);
        pthread_mutex_unlock(&w->lock);
        return ff_writer_wait(w);
    }
    w->data = data;
    w->offset = offset;
    w->bytes = bytes;
    w->pending = w->threads;
    w->job_start = rad_clock_seconds();
    w->job++;
    pthread_cond_broadcast(&w->work);
    pthread_mutex_unlock(&w->lock);
    return RAD_OK;
}

rad_status ff_writer_write(ff_writer *w, uint64_t offset, const void *data, uint64_t bytes)
{
    rad_status status = ff_writer_wait(w);
    if (status != RAD_OK) return status;
    int error = write_plain(w->fd, offset, data, bytes);
    if (error) {
        pthread_mutex_lock(&w->lock);
        if (!w->error) w->error = error, w->error_offset = offset;
        pthread_mutex_unlock(&w->lock);
        return ff_writer_wait(w);
    }
    w->written += bytes; /* no write in flight */
    return RAD_OK;
}

double ff_writer_seconds(const ff_writer *w) { return w->seconds; }
uint64_t ff_writer_bytes(const ff_writer *w) { return w->written; }
const char *ff_writer_method_name(const ff_writer *w) { return atomic_load(&((ff_writer *)w)->map) ? "map" : "pwrite"; }

rad_status ff_writer_close(ff_writer *w)
{
    if (!w) return RAD_OK;
    rad_status status = ff_writer_wait(w);
    pthread_mutex_lock(&w->lock);
    w->stop = 1;
    pthread_cond_broadcast(&w->work);
    pthread_mutex_unlock(&w->lock);
    for (int k = 0; k < w->threads; k++) pthread_join(w->thread[k].id, NULL);
    if (close(w->fd) != 0 && status == RAD_OK) {
        rad_error("%s: close failed: %s", w->path, strerror(errno));
        status = RAD_ERR_IO;
    }
    pthread_mutex_destroy(&w->lock);
    pthread_cond_destroy(&w->work);
    pthread_cond_destroy(&w->idle);
    free(w);
    return status;
}
