/* ff_writer.h - one rank's share of a file that every rank writes at once,
 * written in the background while the rank computes its next rows.
 *
 *     ff_writer *w;
 *     ff_writer_open(path, &options, &w);      // the file exists (rad_fs_temp_create)
 *     for each round:
 *         ff_writer_submit(w, offset, data, bytes, end);  // waits for the last one, then returns
 *         ...                                  // compute the next round into another buffer
 *     status = ff_writer_wait(w);              // every submitted write done (the first failure)
 *     ff_writer_write(w, offset, data, bytes); // a synchronous write (rank 0's header)
 *     status = ff_writer_close(w);
 *
 * Each rank opens the file itself and writes its own byte ranges, which no
 * other rank writes: no collective call, no rank waits for another's
 * write. The ranges come from the caller's layout (ff_output.c: an
 * exclusive scan of the ranks' sizes), so the bytes do not depend on how
 * or when they are written.
 *
 * One write is in flight at a time: submit first waits for the previous
 * one, so the caller's buffer of a submit stays in use until the next
 * submit (or wait, or close) returns - two buffers in turn keep the
 * computation going while the other one is written. The writer's threads
 * (options.threads, at most FF_WRITER_MAX_THREADS) take slices of it.
 *
 * Two ways to put the bytes in the file (docs/architecture.md, "Writing
 * the file"): pwrite, anywhere; and, for a regular file on a local file
 * system (tmpfs, ext4, xfs, btrfs, overlayfs), through a shared mapping of the range
 * (mmap, MADV_POPULATE_WRITE, memcpy). Linux serialises buffered writes to
 * one file (the inode's lock), so pwrite from four ranks goes no faster
 * than from one; page faults on a mapping do not take that lock. Where the
 * mapping cannot be made (another file system, a device such as
 * /dev/null, a kernel before 5.14 without MADV_POPULATE_WRITE) the writer
 * falls back to pwrite. A full file system fails the write with a message
 * either way (the populate step reports it; no SIGBUS on the copy).
 *
 * Errors: the first failed write is logged once ("path: write failed:
 * why") by the thread that calls submit, wait or close, which return
 * RAD_ERR_IO from then on; later writes are skipped.
 */
#ifndef FF_WRITER_H
#define FF_WRITER_H

#include <stdint.h>

#include "rad_status.h"

/* Threads one writer uses at most: enough to fill a node's memory
 * bandwidth with page faults from several ranks; more only contend. */
#define FF_WRITER_MAX_THREADS 4

typedef enum ff_write_method {
    FF_WRITE_AUTO = 0, /* a mapping where the file allows it, else pwrite */
    FF_WRITE_PWRITE,   /* pwrite only (RAD_FF_WRITE=pwrite: tests and benchmarks compare the two) */
    FF_WRITE_MAP       /* as auto (a mapping cannot be forced where the file refuses it) */
} ff_write_method;

typedef struct ff_writer_options {
    int threads;            /* background threads, 0 = 1; capped at FF_WRITER_MAX_THREADS */
    ff_write_method method; /* 0 = auto */
} ff_writer_options;

typedef struct ff_writer ff_writer;

/* Opens `path` (it exists; no symlink followed) for writing. Logs and
 * returns RAD_ERR_IO (or RAD_ERR_NOMEM) on failure. */
rad_status ff_writer_open(const char *path, const ff_writer_options *options, ff_writer **out_writer);
/* Waits for the previous write, then starts writing `bytes` of `data` at
 * `offset` and returns. `file_end`: where the file ends once every rank's
 * writes so far are done (the same on every rank in a round, never
 * smaller than the last round's): a mapped file is grown to it first, so
 * ranks only ever lengthen it. bytes may be 0. */
rad_status ff_writer_submit(ff_writer *writer, uint64_t offset, const void *data, uint64_t bytes, uint64_t file_end);
/* Waits for the write in flight. */
rad_status ff_writer_wait(ff_writer *writer);
/* Waits, then writes `bytes` of `data` at `offset` itself (pwrite). */
rad_status ff_writer_write(ff_writer *writer, uint64_t offset, const void *data, uint64_t bytes);
/* Seconds writes were in flight (from each submit until its write was
 * done) and bytes written so far; "map" or "pwrite", how they went. */
double ff_writer_seconds(const ff_writer *writer);
uint64_t ff_writer_bytes(const ff_writer *writer);
const char *ff_writer_method_name(const ff_writer *writer);
/* Waits, stops the threads, closes the file, frees the writer (NULL is
 * fine); the first failure of any write or of the close. */
rad_status ff_writer_close(ff_writer *writer);

#endif
