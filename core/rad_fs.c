#define _POSIX_C_SOURCE 200809L
#include "rad_fs.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rad_log.h"

rad_status rad_fs_temp_path(const char *final_path, char *out, size_t out_size)
{
    int n = snprintf(out, out_size, "%s.tmp-%ld", final_path, (long)getpid());
    if (n < 0 || (size_t)n >= out_size) {
        rad_error("%s: output path too long", final_path);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

rad_status rad_fs_commit(const char *temp_path, const char *final_path)
{
    if (rename(temp_path, final_path) != 0) {
        rad_error("%s: cannot rename %s over it: %s", final_path, temp_path, strerror(errno));
        remove(temp_path);
        return RAD_ERR_IO;
    }
    return RAD_OK;
}

void rad_fs_discard(const char *temp_path) { remove(temp_path); }

rad_status rad_fs_create_temp(const char *final_path, char *temp, size_t temp_size, FILE **out_file)
{
    rad_status status = rad_fs_temp_path(final_path, temp, temp_size);
    if (status != RAD_OK) return status;
    FILE *f = fopen(temp, "w");
    if (!f) {
        rad_error("%s: cannot create: %s", temp, strerror(errno));
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

rad_status rad_fs_read_all(const char *path, char **out_data, size_t *out_size)
{
    rad_status status = RAD_ERR_IO;
    char *data = NULL;
    *out_data = NULL;
    *out_size = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        rad_error("%s: cannot open: %s", path, strerror(errno));
        return RAD_ERR_IO;
    }
    size_t cap = 1 << 16, size = 0;
    data = malloc(cap + 1);
    if (!data) { status = RAD_ERR_NOMEM; goto done; }
    for (;;) {
        size_t got = fread(data + size, 1, cap - size, f);
        size += got;
        if (size < cap) break;
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
