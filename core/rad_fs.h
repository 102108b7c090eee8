/* rad_fs.h - files that appear whole or not at all.
 *
 * Every output goes to a temporary name beside the final one
 * ("<final>.tmp-<pid>", same directory so rename is atomic), and is renamed
 * over the final name only after it was completely written and closed. On
 * failure the temporary is removed and an existing file under the final
 * name is left untouched.
 */
#ifndef RAD_FS_H
#define RAD_FS_H

#include <stddef.h>
#include <stdio.h>

#include "rad_status.h"

/* Writes "<final_path>.tmp-<pid>" into out (size out_size). */
rad_status rad_fs_temp_path(const char *final_path, char *out, size_t out_size);
/* fsync-free rename of tmp over final; logs "final: cannot rename: why". */
rad_status rad_fs_commit(const char *temp_path, const char *final_path);
/* Removes a temporary after a failure (ignores errors). */
void rad_fs_discard(const char *temp_path);
/* Text outputs (JSON stats): opens "<final>.tmp-<pid>" for writing; the
 * temporary's name goes to temp (size temp_size). */
rad_status rad_fs_create_temp(const char *final_path, char *temp, size_t temp_size, FILE **out_file);
/* Closes f and renames temp over final_path if every write succeeded;
 * otherwise removes temp. Logs "temp: write failed: why". */
rad_status rad_fs_close_commit(FILE *f, const char *temp, const char *final_path);

/* Reads a whole file (for loaders); *out_data is NUL-terminated, free() it. */
rad_status rad_fs_read_all(const char *path, char **out_data, size_t *out_size);

#endif
