/* fuzz_common.h - what the three fuzz targets share.
 *
 * Each target defines LLVMFuzzerTestOneInput; it is linked either with
 * libFuzzer (clang -fsanitize=fuzzer, RAD_FUZZ=ON) or with replay.c, a
 * plain main() that feeds files to it (the regression tests of normal CI).
 *
 * The readers under test take a path, so the input is written to one
 * memfd per process and read back through /proc/self/fd/N: no disk I/O,
 * no temporary files left behind by a crash.
 */
#ifndef FUZZ_COMMON_H
#define FUZZ_COMMON_H

#ifndef _GNU_SOURCE
#define _GNU_SOURCE /* memfd_create; include this header first */
#endif
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "rad_log.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Formats every message (so format strings meet fuzzed text) and drops it. */
static void fuzz_discard_sink(rad_log_level level, const char *message, void *user)
{
    (void)level, (void)message, (void)user;
}

static inline void fuzz_quiet_logger(void)
{
    rad_log_set_sink(fuzz_discard_sink, NULL);
    rad_log_set_level(RAD_LOG_DEBUG);
}

/* Replaces the contents of the process's memfd with data; returns its
 * path, or aborts (an environment failure, not a finding). */
static inline const char *fuzz_memfd_write(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[64];
    if (fd < 0) {
        fd = memfd_create("rad_fuzz", 0);
        if (fd < 0) {
            perror("memfd_create");
            abort();
        }
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    if (ftruncate(fd, 0) != 0) abort();
    size_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(fd, data + done, size - done, (off_t)done);
        if (n <= 0) abort();
        done += (size_t)n;
    }
    return path;
}

/* "DIR/name" in a directory of this process under /dev/shm (or /tmp):
 * for writers, which write through a temporary name and a rename. At
 * most FUZZ_SCRATCH_FILES names; removed with the directory at exit. */
#define FUZZ_SCRATCH_FILES 4
static char fuzz_scratch_dir[64], fuzz_scratch_names[FUZZ_SCRATCH_FILES][128];

static void fuzz_scratch_remove(void)
{
    for (int i = 0; i < FUZZ_SCRATCH_FILES; i++)
        if (fuzz_scratch_names[i][0]) remove(fuzz_scratch_names[i]);
    rmdir(fuzz_scratch_dir);
}

static inline const char *fuzz_scratch_path(const char *name)
{
    if (!fuzz_scratch_dir[0]) {
        snprintf(fuzz_scratch_dir, sizeof fuzz_scratch_dir, "%s/rad_fuzz.XXXXXX",
                 access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp");
        if (!mkdtemp(fuzz_scratch_dir)) {
            perror("mkdtemp");
            abort();
        }
        atexit(fuzz_scratch_remove);
    }
    char path[128];
    snprintf(path, sizeof path, "%s/%s", fuzz_scratch_dir, name);
    for (int i = 0; i < FUZZ_SCRATCH_FILES; i++) {
        if (!fuzz_scratch_names[i][0]) memcpy(fuzz_scratch_names[i], path, sizeof path);
        if (strcmp(fuzz_scratch_names[i], path) == 0) return fuzz_scratch_names[i];
    }
    abort(); /* more names than FUZZ_SCRATCH_FILES: a bug in the target */
}

/* A check that must hold for whatever a reader accepted: a violation is a
 * finding, so it aborts like a sanitizer would. */
#define FUZZ_REQUIRE(cond)                                                              \
    do {                                                                                \
        if (!(cond)) {                                                                  \
            fprintf(stderr, "%s:%d: accepted input violates: %s\n", __FILE__, __LINE__, #cond); \
            abort();                                                                    \
        }                                                                               \
    } while (0)

/* The binary readers' entry: the input as it is (magic, version, size and
 * checksum checks), then a copy whose checksums `repair` recomputed from
 * what its header claims (so mutations reach the checks behind them). */
static inline int fuzz_read_as_is_and_repaired(const uint8_t *data, size_t size, void (*read_back)(const char *),
                                               int (*repair)(uint8_t *, size_t))
{
    static int ready;
    if (!ready) {
        fuzz_quiet_logger();
        ready = 1;
    }
    read_back(fuzz_memfd_write(data, size));
    uint8_t *copy = malloc(size ? size : 1);
    if (!copy) return 0;
    memcpy(copy, data, size);
    if (repair(copy, size)) read_back(fuzz_memfd_write(copy, size));
    free(copy);
    return 0;
}

#endif
