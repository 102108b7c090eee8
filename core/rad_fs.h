/* rad_fs.h - files that appear whole or not at all.
 *
 * Every output goes to a temporary name beside the final one
 * ("<final>.tmp-<random>", same directory so rename is atomic), created
 * exclusively, and is renamed over the final name only after it was
 * completely written and closed. On failure, or on a termination signal,
 * the temporary is removed and an existing file under the final name is
 * left untouched. docs/reliability.md, "Threat model: files on disk".
 */
#ifndef RAD_FS_H
#define RAD_FS_H

#include <stddef.h>
#include <stdio.h>

#include "rad_status.h"

/* Creates the temporary for final_path exclusively: "<final>.tmp-" and 16
 * random hex digits, beside it, with O_CREAT | O_EXCL | O_NOFOLLOW (a name
 * planted in advance, symlink or not, is never written through; mode
 * 0666 less the umask, as a plain file), empty, and guarded: a catchable
 * termination signal removes it (rad_fs_guard). Its name goes to out.
 * Where final_path is an existing character device (/dev/null), out is
 * final_path itself: written in place, never renamed or removed. Other
 * kinds are refused before (rad_fs_check_output). */
rad_status rad_fs_temp_create(const char *final_path, char *out, size_t out_size);
/* Opens a temporary from rad_fs_temp_create (or the device it stands for)
 * for writing, without following a symlink; NULL with errno on failure. */
FILE *rad_fs_temp_open(const char *temp);
/* Renames temp over final_path and unguards it (nothing to do for a
 * device written in place); logs "final: cannot rename: why" and removes
 * the temporary on failure. */
rad_status rad_fs_commit(const char *temp_path, const char *final_path);
/* Removes a temporary after a failure, if it is one this process created
 * or guards (never a device written in place); ignores errors. */
void rad_fs_discard(const char *temp_path);
/* Text outputs (JSON stats): creates the temporary and opens it; its name
 * goes to temp (size temp_size). */
rad_status rad_fs_create_temp(const char *final_path, char *temp, size_t temp_size, FILE **out_file);
/* Closes f and renames temp over final_path if every write succeeded;
 * otherwise removes temp. Logs "temp: write failed: why". */
rad_status rad_fs_close_commit(FILE *f, const char *temp, const char *final_path);

/* The signal guard: names registered here are unlinked when the process
 * gets SIGTERM, SIGINT, SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2, SIGALRM,
 * SIGPIPE, SIGXCPU, SIGXFSZ, SIGVTALRM, SIGPROF, SIGSEGV, SIGBUS, SIGFPE,
 * SIGILL or SIGABRT, which then kills it as it would have; the timer
 * signals (SIGALRM, SIGVTALRM, SIGPROF) only where they have no handler
 * already (a profiler's or a fuzzer's ticks do not end the process).
 * rad_fs_temp_create registers its temporaries; another
 * process that knows one's name (the other MPI ranks) registers it too.
 * At most RAD_FS_GUARD_SLOTS at once (a full guard logs and returns
 * RAD_ERR_NOMEM). Unguarding a name not registered does nothing. */
#define RAD_FS_GUARD_SLOTS 8
rad_status rad_fs_guard(const char *temp_path);
void rad_fs_unguard(const char *temp_path);

/* Outputs are new files, regular files, or character devices (written in
 * place: `-o /dev/null` times a run). A directory, FIFO, socket or block
 * device, or an empty name, is refused: "option: path: why" (logged); so
 * is a new or regular file whose folder is missing, not a folder, or does
 * not take new files (its temporary is made there). Called for every
 * output before any work. */
rad_status rad_fs_check_output(const char *option, const char *path);

/* One file a program reads or writes, named by the option that gave it. */
typedef struct rad_fs_role {
    const char *option; /* "-o", "--stats", "scene", ... */
    const char *path;   /* NULL: not given (skipped) */
    int output;         /* 1: written, 0: read */
} rad_fs_role;
/* Refuses, before any work, two roles that name one file where either is
 * written: existing files are compared by device and inode (hard links,
 * symlinks and other spellings included), files still to be made by
 * their folder's identity and their name. Logs "A and B name the same
 * file (path)" and returns RAD_ERR_USAGE. Character devices may be shared
 * by outputs (-o /dev/null --stats /dev/null). */
rad_status rad_fs_check_roles(const rad_fs_role *roles, size_t count);

/* Opens an input for reading: a regular file (through symlinks) or
 * nothing. A directory, FIFO, device or socket is refused before a byte
 * is read - opened without blocking, so a FIFO cannot hang the program,
 * and never read, so /dev/zero cannot fill memory. NULL on failure, with
 * "path: why" logged. */
FILE *rad_fs_open_input(const char *path);

/* Largest file rad_fs_read_all reads (scenes, materials, cameras). */
#define RAD_FS_READ_MAX ((size_t)1 << 30)
/* Reads a whole input (rad_fs_open_input, at most RAD_FS_READ_MAX bytes);
 * *out_data is NUL-terminated, free() it. */
rad_status rad_fs_read_all(const char *path, char **out_data, size_t *out_size);

#endif
