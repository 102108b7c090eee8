/* groups.c - results by surface, written as CSV or .npy (contract in
 * groups.h). */
#define _POSIX_C_SOURCE 200809L
#include "groups.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_bytes.h"
#include "rad_fs.h"
#include "rad_log.h"
#include "run.h" /* SOLVE_PARALLEL_MIN_ROWS */

typedef struct group_row {
    uint64_t patches;
    double area;
    double radiosity[3]; /* sum A_i B_i until divided by the area */
    double emitted[3];
    double absorbed[3];
} group_row;

static int ends_with(const char *path, const char *extension)
{
    size_t n = strlen(path), e = strlen(extension);
    if (n <= e) return 0;
    for (size_t k = 0; k < e; k++)
        if (tolower((unsigned char)path[n - e + k]) != extension[k]) return 0;
    return 1;
}

rad_status solve_groups_format_of(const char *option, const char *path, solve_groups_format *out_format)
{
    if (ends_with(path, ".csv")) {
        *out_format = SOLVE_GROUPS_CSV;
    } else if (ends_with(path, ".npy")) {
        *out_format = SOLVE_GROUPS_NPY;
    } else {
        rad_error("%s: '%s': the name must end in .csv or .npy", option, path);
        return RAD_ERR_USAGE;
    }
    return RAD_OK;
}

/* The rows of every group. `H` holds N doubles of scratch, `absorbed`
 * 3 G. Across ranks each rank adds up what its rows absorb, and the sums
 * are added over the ranks (one MPI_Allreduce). */
static void compute_rows(const solve_system *system, const rad_mesh *mesh, const double *radiosity, double *B,
                         double *H, double *absorbed, group_row *rows)
{
    const size_t n = mesh->patch_count;
    const solve_rows F = solve_system_rows(system);
    size_t begin, end;
    solve_system_held(system, &begin, &end);
    memset(absorbed, 0, 3 * mesh->group_count * sizeof *absorbed);
    memset(rows, 0, mesh->group_count * sizeof *rows);
    for (size_t i = 0; i < n; i++) {
        group_row *r = &rows[mesh->patch_group[i]];
        const rad_patch *p = &mesh->patches[i];
        r->patches++;
        r->area += p->area;
        for (int c = 0; c < 3; c++) {
            r->radiosity[c] += p->area * radiosity[3 * i + c];
            r->emitted[c] += p->area * p->emission[c];
        }
    }
    for (int c = 0; c < 3; c++) {
        for (size_t i = 0; i < n; i++) B[i] = radiosity[3 * i + c];
#pragma omp parallel for schedule(static) if (end - begin >= SOLVE_PARALLEL_MIN_ROWS)
        for (size_t i = begin; i < end; i++) H[i] = solve_row_dot(&F, i, B, 0, n);
        for (size_t i = begin; i < end; i++) {
            const rad_patch *p = &mesh->patches[i];
            absorbed[3 * mesh->patch_group[i] + c] += p->area * (1 - p->rho[c]) * H[i];
        }
    }
    solve_comm_sum(system->comm, absorbed, 3 * mesh->group_count);
    for (size_t g = 0; g < mesh->group_count; g++)
        for (int c = 0; c < 3; c++) rows[g].absorbed[c] = absorbed[3 * g + c];
    for (size_t g = 0; g < mesh->group_count; g++)
        for (int c = 0; c < 3; c++) rows[g].radiosity[c] /= rows[g].area;
}

/* A CSV field: quoted when it holds a comma, quote or line break. */
static void put_csv_name(FILE *f, const char *name)
{
    if (!strpbrk(name, ",\"\r\n")) {
        fputs(name, f);
        return;
    }
    fputc('"', f);
    for (const char *p = name; *p; p++) {
        if (*p == '"') fputc('"', f);
        fputc(*p, f);
    }
    fputc('"', f);
}

static void put_csv(FILE *f, const rad_mesh *mesh, const group_row *rows)
{
    fputs("group,patches,area,radiosity_r,radiosity_g,radiosity_b,emitted_r,emitted_g,emitted_b,"
          "absorbed_r,absorbed_g,absorbed_b\n",
          f);
    for (size_t g = 0; g < mesh->group_count; g++) {
        const group_row *r = &rows[g];
        put_csv_name(f, mesh->group_names[g]);
        fprintf(f, ",%llu,%.17g", (unsigned long long)r->patches, r->area);
        const double *columns[3] = {r->radiosity, r->emitted, r->absorbed};
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++) fprintf(f, ",%.17g", columns[k][c]);
        fputc('\n', f);
    }
}

/* NPY format 1.0: magic, version, u16 header length, a Python dict padded
 * with spaces to a multiple of 64 bytes and ended by a newline, then the
 * records, packed, little-endian. */
#define NPY_RECORD_BYTES (RAD_NAME_MAX + 8 + 8 + 3 * 3 * 8)

static void put_npy(FILE *f, const rad_mesh *mesh, const group_row *rows)
{
    char dict[256];
    int len = snprintf(dict, sizeof dict,
                       "{'descr': [('group', '|S%d'), ('patches', '<u8'), ('area', '<f8'), "
                       "('radiosity', '<f8', (3,)), ('emitted', '<f8', (3,)), ('absorbed', '<f8', (3,))], "
                       "'fortran_order': False, 'shape': (%zu,), }",
                       RAD_NAME_MAX, mesh->group_count);
    size_t total = 10 + (size_t)len + 1;
    size_t padded = (total + 63) / 64 * 64;
    unsigned char preamble[10] = {0x93, 'N', 'U', 'M', 'P', 'Y', 1, 0, 0, 0};
    preamble[8] = (unsigned char)((padded - 10) & 0xff);
    preamble[9] = (unsigned char)((padded - 10) >> 8);
    fwrite(preamble, 1, sizeof preamble, f);
    fwrite(dict, 1, (size_t)len, f);
    for (size_t k = total; k < padded; k++) fputc(' ', f);
    fputc('\n', f);
    for (size_t g = 0; g < mesh->group_count; g++) {
        const group_row *r = &rows[g];
        unsigned char record[NPY_RECORD_BYTES];
        memset(record, 0, sizeof record);
        memcpy(record, mesh->group_names[g], strnlen(mesh->group_names[g], RAD_NAME_MAX));
        unsigned char *p = record + RAD_NAME_MAX;
        rad_put_u64(p, r->patches);
        rad_put_f64(p + 8, r->area);
        p += 16;
        const double *columns[3] = {r->radiosity, r->emitted, r->absorbed};
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++, p += 8) rad_put_f64(p, columns[k][c]);
        fwrite(record, 1, sizeof record, f);
    }
}

rad_status solve_groups_write(const char *path, const solve_system *system, const rad_mesh *mesh,
                              const double *radiosity)
{
    solve_groups_format format;
    rad_status status = solve_groups_format_of("--by-group", path, &format);
    if (status != RAD_OK) return status;
    if (mesh->group_count == 0 || !mesh->patch_group) {
        rad_error("internal: --by-group without a group table");
        return RAD_ERR_INVALID;
    }
    const size_t n = mesh->patch_count;
    group_row *rows = malloc(mesh->group_count * sizeof *rows);
    double *scratch = malloc((2 * n + 3 * mesh->group_count) * sizeof *scratch);
    if (!rows || !scratch) rad_error("%s: out of memory for %zu groups", path, mesh->group_count);
    status = solve_comm_agree(system->comm, rows && scratch ? RAD_OK : RAD_ERR_NOMEM);
    if (status != RAD_OK) {
        free(rows);
        free(scratch);
        return status;
    }
    compute_rows(system, mesh, radiosity, scratch, scratch + n, scratch + 2 * n, rows);
    char temp[4096];
    FILE *f = NULL;
    if (solve_comm_rank(system->comm) == 0) status = rad_fs_create_temp(path, temp, sizeof temp, &f);
    if (status == RAD_OK && f) {
        if (format == SOLVE_GROUPS_CSV)
            put_csv(f, mesh, rows);
        else
            put_npy(f, mesh, rows);
        status = rad_fs_close_commit(f, temp, path);
    }
    free(rows);
    free(scratch);
    return solve_comm_agree(system->comm, status);
}
