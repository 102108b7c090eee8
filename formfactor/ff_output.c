#include "ff_output.h"

#include <assert.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ff_writer.h"
#include "rad_fs.h"
#include "rad_log.h"

#define FF_OUTPUT_MAX_BYTES ((uint64_t)1 << 28) /* 256 MiB per write */

struct ff_output {
    ff_comm *comm;
    ff_writer *writer;
    ff_format format;
    char path[4096], temp[4096];
    rad_ff_info info;
    rad_ff_layout layout;
    unsigned char *prologue; /* rank 0, native format */
    size_t prologue_size;
    uint64_t *row_checksums; /* this rank's rows, in the order written */
    uint64_t *row_offsets;   /* sparse: their records' offsets from the matrix offset */
    uint64_t *row_numbers;   /* which rows they are: a rank's rows need not be contiguous */
    uint64_t checksum_count, checksum_cap;
    uint64_t record_max;     /* bytes one row can take as stored */
    uint64_t appended;       /* sparse: bytes of records written so far, all ranks */
    uint64_t *record_at[2];  /* a write's records' offsets in `convert` (row_count + 1), one per buffer */
    uint64_t record_cap[2];
    int threads;
    int reserved;            /* sparse: ff_output_reserve placed this rank's records */
    uint64_t reserved_at;    /* … the next one's offset */
    /* Rows in the stored element type, two buffers in turn: one is being
     * written in the background while the next write fills the other. */
    void *convert[2];
    uint64_t convert_bytes[2]; /* their sizes: grown to the largest write seen */
    int turn;                  /* the buffer the next ff_output_write_rows fills */
    ff_output_write_stats written; /* this rank's writes, once closed */
    /* ff_output_open_held: this rank's records handed over, no file (writer NULL) */
    ff_handoff *handoff;
};

/* Bytes one row can take as stored: the dense row, or the largest sparse record; at least 1. */
static uint64_t record_max_of(uint64_t patch_count, ff_format format, rad_element_type element)
{
    if (format == FF_FORMAT_PAPER) element = RAD_ELEMENT_F64;
    uint64_t bytes = format == FF_FORMAT_SPARSE ? rad_ff_row_record_max(patch_count, element)
                                                : patch_count * (element == RAD_ELEMENT_F32 ? 4 : 8);
    return bytes ? bytes : 1;
}

uint32_t ff_output_max_rows(uint64_t patch_count, ff_format format, rad_element_type element)
{
    uint64_t rows = FF_OUTPUT_MAX_BYTES / record_max_of(patch_count, format, element);
    return rows ? (uint32_t)rows : 1;
}

/* Everything an output owns (NULL is fine); its file is closed or
 * committed first. */
static void output_free(ff_output *o)
{
    if (!o) return;
    ff_handoff_close(o->handoff);
    free(o->prologue);
    free(o->convert[0]);
    free(o->convert[1]);
    free(o->row_checksums);
    free(o->row_offsets);
    free(o->row_numbers);
    free(o->record_at[0]);
    free(o->record_at[1]);
    free(o);
}

/* An output's common part (the file's and the held one's): its info and
 * layout for `format`, and the two encode buffers, sized by the first
 * write (ff_output_write_rows), not by the largest write allowed: that
 * could be 256 MiB more than needed. NULL (logged) when out of memory. */
static ff_output *output_new(ff_comm *comm, const char *path, ff_format format, const rad_ff_info *info,
                             const ff_output_options *options)
{
    ff_output *o = calloc(1, sizeof *o);
    if (o) {
        o->comm = comm;
        o->format = format;
        o->threads = options && options->threads > 0 ? options->threads : 1;
        o->info = *info;
        if (format == FF_FORMAT_PAPER) o->info.element_type = RAD_ELEMENT_F64;
        o->info.layout = format == FF_FORMAT_SPARSE ? RAD_FF_LAYOUT_SPARSE : RAD_FF_LAYOUT_DENSE;
        o->info.matrix_bytes = 0;
        o->layout = rad_ff_layout_of(&o->info);
        o->record_max = record_max_of(info->patch_count, format, (rad_element_type)info->element_type);
        snprintf(o->path, sizeof o->path, "%s", path);
        for (int k = 0; k < 2; k++) {
            o->convert[k] = malloc(RAD_FF_ALIGN);
            o->convert_bytes[k] = RAD_FF_ALIGN;
        }
    }
    if (!o || !o->convert[0] || !o->convert[1]) {
        rad_error("%s: out of memory", path);
        output_free(o);
        return NULL;
    }
    return o;
}

rad_status ff_output_open(ff_comm *comm, const char *path, ff_format format, const rad_ff_info *info,
                          const rad_mesh *mesh, const ff_output_options *options, ff_output **out_output)
{
    ff_output *o = output_new(comm, path, format, info, options);
    rad_status status = o ? RAD_OK : RAD_ERR_NOMEM;
    if (status == RAD_OK) {
        if (ff_comm_rank(comm) == 0) status = rad_fs_check_output("-o", path);
        /* Rank 0 creates the temporary (exclusively, guarded); the others
         * learn its name below and guard it too: a rank that is
         * signalled removes it whichever it is (mpirun terminates the
         * others when one dies; a batch system's time limit; Ctrl-C). */
        if (status == RAD_OK && ff_comm_rank(comm) == 0) status = rad_fs_temp_create(path, o->temp, sizeof o->temp);
        if (status == RAD_OK && ff_comm_rank(comm) == 0 && format != FF_FORMAT_PAPER)
            status = rad_ff_prologue_encode(&o->info, mesh, &o->prologue, &o->prologue_size);
    }
    status = ff_comm_agree(comm, status);
    if (status == RAD_OK) {
        ff_comm_broadcast(comm, o->temp, sizeof o->temp, 0);
        if (ff_comm_rank(comm) != 0 && strcmp(o->temp, path)) status = rad_fs_guard(o->temp);
        status = ff_comm_agree(comm, status);
        /* Every rank opens the file itself and writes its own ranges (ff_writer.h). */
        ff_writer_options wo = {.threads = options ? options->write_threads : 0,
                                .method = options ? options->write_method : FF_WRITE_AUTO};
        if (status == RAD_OK) status = ff_writer_open(o->temp, &wo, &o->writer);
        status = ff_comm_agree(comm, status);
        if (status != RAD_OK) {
            ff_writer_close(o->writer);
            o->writer = NULL;
            if (ff_comm_rank(comm) == 0)
                rad_fs_discard(o->temp);
            else
                rad_fs_unguard(o->temp);
        }
    } else if (o && ff_comm_rank(comm) == 0 && o->temp[0]) {
        rad_fs_discard(o->temp);
    }
    if (status != RAD_OK) {
        output_free(o);
        return status;
    }
    *out_output = o;
    return RAD_OK;
}

rad_status ff_output_open_held(ff_comm *comm, const rad_ff_info *info, ff_handoff_consume consume, void *user,
                               const ff_output_options *options, ff_output **out_output)
{
    ff_output *o = output_new(comm, "(in memory)", FF_FORMAT_SPARSE, info, options);
    rad_status status = o ? ff_handoff_open(consume, user, &o->handoff) : RAD_ERR_NOMEM;
    status = ff_comm_agree(comm, status);
    if (status != RAD_OK) {
        output_free(o);
        return status;
    }
    *out_output = o;
    return RAD_OK;
}

rad_status ff_output_reserve(ff_output *o, uint32_t row_count, const double *rows)
{
    if (o->format != FF_FORMAT_SPARSE || o->handoff) return RAD_OK;
    uint64_t n = o->info.patch_count, bytes = 0, total = 0;
#pragma omp parallel for num_threads(o->threads) schedule(dynamic, 16) reduction(+ : bytes)
    for (uint32_t r = 0; r < row_count; r++) bytes += rad_ff_row_encode(rows + (uint64_t)r * n, n, o->info.element_type, NULL);
    o->reserved_at = o->appended + ff_comm_exscan_u64(o->comm, bytes, &total);
    o->appended += total;
    o->reserved = 1;
    return RAD_OK;
}

static rad_status place_and_write(ff_output *o, uint32_t row_begin, uint64_t first, uint64_t bytes, const void *data,
                                  rad_status status);

static rad_status grow_row_tables(ff_output *o, uint32_t row_count)
{
    if (o->checksum_count + row_count <= o->checksum_cap) return RAD_OK;
    uint64_t cap = o->checksum_cap ? 2 * o->checksum_cap : 1024;
    while (cap < o->checksum_count + row_count) cap *= 2;
    uint64_t *checksums = realloc(o->row_checksums, cap * 8);
    if (checksums) o->row_checksums = checksums;
    uint64_t *offsets = checksums ? realloc(o->row_offsets, cap * 8) : NULL;
    if (offsets) o->row_offsets = offsets;
    uint64_t *numbers = offsets ? realloc(o->row_numbers, cap * 8) : NULL;
    if (numbers) o->row_numbers = numbers;
    if (!checksums || !offsets || !numbers) {
        rad_error("out of memory for row checksums");
        return RAD_ERR_NOMEM;
    }
    o->checksum_cap = cap;
    return RAD_OK;
}

rad_status ff_output_write_rows(ff_output *o, uint32_t row_begin, uint32_t row_count, const double *rows)
{
    uint64_t n = o->info.patch_count, rb = o->layout.row_bytes, max = o->record_max;
    int sparse = o->format == FF_FORMAT_SPARSE;
    rad_status status = RAD_OK;
    if ((uint64_t)row_count * max > FF_OUTPUT_MAX_BYTES) {
        rad_error("internal: %u rows exceed one write", row_count);
        status = RAD_ERR_INVALID;
        row_count = 0;
    }
    if (status == RAD_OK && !o->handoff && (status = grow_row_tables(o, row_count)) != RAD_OK) row_count = 0;
    /* The other buffer may still be being written; this one is free: its
     * write was waited for when the other one's began (ff_writer_submit). */
    int turn = o->turn;
    if ((uint64_t)row_count * max > o->convert_bytes[turn]) {
        void *grown = realloc(o->convert[turn], (size_t)(row_count * max));
        if (!grown) {
            rad_error("out of memory for %u rows of output (%llu bytes)", row_count,
                      (unsigned long long)(row_count * max));
            status = RAD_ERR_NOMEM;
            row_count = 0;
        } else {
            o->convert[turn] = grown;
            o->convert_bytes[turn] = (uint64_t)row_count * max;
        }
    }
    if (row_count + 1 > o->record_cap[turn]) {
        uint64_t *grown = realloc(o->record_at[turn], (row_count + 1) * sizeof *grown);
        if (!grown) {
            rad_error("out of memory for %u rows of output", row_count);
            status = RAD_ERR_NOMEM;
            row_count = 0;
        } else {
            o->record_at[turn] = grown;
            o->record_cap[turn] = row_count + 1;
        }
    }
    /* Sizes, then where each record goes, then the records themselves,
     * each row on its own: the same bytes for any number of threads. */
    uint64_t *at = o->record_at[turn], first = o->checksum_count;
    int keep_index = !o->handoff; /* a handed-over matrix has no row index */
    int64_t count = row_count;
#pragma omp parallel for num_threads(o->threads) schedule(dynamic, 16)
    for (int64_t r = 0; r < count; r++)
        at[r + 1] = sparse ? rad_ff_row_encode(rows + (uint64_t)r * n, n, o->info.element_type, NULL) : rb;
    if (at) at[0] = 0;
    for (int64_t r = 0; r < count; r++) at[r + 1] += at[r];
#pragma omp parallel for num_threads(o->threads) schedule(dynamic, 16)
    for (int64_t r = 0; r < count; r++) {
        unsigned char *dst = (unsigned char *)o->convert[turn] + at[r];
        const double *src = rows + (uint64_t)r * n;
        if (sparse)
            rad_ff_row_encode(src, n, o->info.element_type, dst);
        else if (o->info.element_type == RAD_ELEMENT_F32)
            for (uint64_t j = 0; j < n; j++) ((float *)dst)[j] = (float)src[j];
        else
            memcpy(dst, src, rb);
        if (!keep_index) continue;
        o->row_offsets[first + r] = at[r]; /* from this write's start, fixed below */
        o->row_checksums[first + r] = rad_ff_row_checksum(dst, at[r + 1] - at[r]);
        o->row_numbers[first + r] = (uint64_t)row_begin + (uint64_t)r;
    }
    o->turn = !turn;
    if (o->handoff) { /* to the consumer, in the background; no file, nothing shared */
        rad_status handed = ff_handoff_submit(o->handoff, row_begin, row_count, o->convert[turn], at);
        return status != RAD_OK ? status : handed;
    }
    o->checksum_count += row_count;
    return place_and_write(o, row_begin, first, row_count ? at[row_count] : 0, o->convert[turn], status);
}

rad_status ff_output_write_records(ff_output *o, uint32_t row_begin, uint32_t row_count, const ff_records *records)
{
    rad_status status = RAD_OK;
    if (o->format != FF_FORMAT_SPARSE || (row_count && records->rows != row_count)) {
        rad_error("internal: %u encoded rows for a %s file", row_count,
                  o->format == FF_FORMAT_SPARSE ? "different number of" : "file that is not sparse:");
        status = RAD_ERR_INVALID;
        row_count = 0;
    }
    if (o->handoff) { /* to the consumer, in the background (the backend keeps them until the call after next) */
        rad_status handed = row_count ? ff_handoff_submit(o->handoff, row_begin, row_count,
                                                          records->bytes + records->at[0], records->at)
                                      : ff_handoff_wait(o->handoff);
        return status != RAD_OK ? status : handed;
    }
    if (status == RAD_OK && (status = grow_row_tables(o, row_count)) != RAD_OK) row_count = 0;
    uint64_t first = o->checksum_count;
    int64_t count = row_count;
#pragma omp parallel for num_threads(o->threads) schedule(dynamic, 16)
    for (int64_t r = 0; r < count; r++) {
        const uint64_t *at = records->at;
        o->row_offsets[first + r] = at[r] - at[0]; /* from this write's start, fixed below */
        o->row_checksums[first + r] = rad_ff_row_checksum(records->bytes + at[r], at[r + 1] - at[r]);
        o->row_numbers[first + r] = (uint64_t)row_begin + (uint64_t)r;
    }
    o->checksum_count += row_count;
    const unsigned char *data = row_count ? records->bytes + records->at[0] : NULL;
    return place_and_write(o, row_begin, first, row_count ? records->at[row_count] - records->at[0] : 0, data,
                           status);
}

/* The end of every write (collective): where this rank's `bytes` of rows
 * [row_begin, ...) go - their place in the dense layout, or (sparse) after
 * the records written so far, by an exclusive scan of the ranks' sizes,
 * which also turns the offsets of the row index entries from `first` on
 * into the file's - and the write itself, started in the background (the
 * last one is waited for first). Returns `status` if it is not RAD_OK. */
static rad_status place_and_write(ff_output *o, uint32_t row_begin, uint64_t first, uint64_t bytes, const void *data,
                                  rad_status status)
{
    uint64_t rb = o->layout.row_bytes;
    uint64_t matrix = o->format == FF_FORMAT_PAPER ? 4 : o->layout.matrix_offset;
    uint64_t offset = matrix + (uint64_t)row_begin * rb;
    uint64_t end = matrix + o->info.patch_count * rb; /* where the matrix ends, once every rank wrote */
    if (o->format == FF_FORMAT_SPARSE) {
        /* Every rank takes part in the scan, as in the write below. */
        uint64_t base;
        if (o->reserved) {
            base = o->reserved_at;
            o->reserved_at += bytes;
        } else {
            uint64_t total = 0;
            base = o->appended + ff_comm_exscan_u64(o->comm, bytes, &total);
            o->appended += total;
        }
        for (uint64_t k = first; k < o->checksum_count; k++) o->row_offsets[k] += base;
        offset = o->layout.matrix_offset + base;
        end = o->layout.matrix_offset + o->appended; /* every rank's records so far: the same on every rank */
    }
    /* No collective here: each rank writes its own bytes (ff_writer.h). */
    rad_status written = ff_writer_submit(o->writer, offset, data, bytes, end);
    return status != RAD_OK ? status : written;
}

/* Rank 0: the leading parts (header + tables, or the paper's int32 N) and
 * the index gathered from all ranks (dense: the row checksums; sparse: the
 * record offsets, then the checksums). */
static rad_status write_prologue(ff_output *o, const uint64_t *index)
{
    if (o->format == FF_FORMAT_PAPER) {
        int32_t n = (int32_t)o->info.patch_count;
        return ff_writer_write(o->writer, 0, &n, 4);
    }
    o->info.matrix_bytes = o->format == FF_FORMAT_SPARSE ? o->appended : 0;
    o->layout = rad_ff_layout_of(&o->info);
    rad_ff_header_finish(o->prologue, &o->info, index);
    rad_status status = ff_writer_write(o->writer, o->layout.row_checksum_offset, index, o->layout.index_bytes);
    if (status == RAD_OK) status = ff_writer_write(o->writer, 0, o->prologue, o->prologue_size);
    return status;
}

/* Collective: every rank's `values`, one per row it wrote, into root's
 * `out` at their rows (`numbers`: the rows gathered; `gathered`: N
 * entries of scratch, root only). */
static void gather_by_row(ff_output *o, const uint64_t *values, const uint64_t *numbers, uint64_t *gathered,
                          uint64_t *out)
{
    ff_comm_gather_u64v(o->comm, values, o->checksum_count, gathered, 0);
    if (ff_comm_rank(o->comm) != 0) return;
    for (uint64_t k = 0; k < o->info.patch_count; k++) out[numbers[k]] = gathered[k];
}

rad_status ff_output_close(ff_output *o, rad_status status)
{
    if (o->handoff) { /* every batch consumed */
        rad_status handed = ff_handoff_wait(o->handoff);
        o->written.seconds = ff_handoff_seconds(o->handoff);
        return ff_comm_agree(o->comm, status != RAD_OK ? status : handed);
    }
    int root = ff_comm_rank(o->comm) == 0;
    uint64_t n = o->info.patch_count, *all = NULL, *numbers = NULL, *gathered = NULL;
    rad_status waited = ff_writer_wait(o->writer); /* this rank's last write */
    if (status == RAD_OK) status = waited;
    status = ff_comm_agree(o->comm, status);
    if (status == RAD_OK) {
        if (root) {
            all = malloc((2 * n + 1) * 8);
            numbers = malloc((n ? n : 1) * 8);
            gathered = malloc((n ? n : 1) * 8);
            if (!all || !numbers || !gathered) rad_error("out of memory gathering row checksums");
        }
        rad_status have = root && !(all && numbers && gathered) ? RAD_ERR_NOMEM : RAD_OK;
        if (ff_comm_agree(o->comm, have) != RAD_OK) status = RAD_ERR_NOMEM;
    }
    if (status == RAD_OK) {
        /* Every row was written once, by some rank, in some round. */
        uint64_t written = 0;
        ff_comm_exscan_u64(o->comm, o->checksum_count, &written);
        if (written != n) {
            if (root)
                rad_error("internal: %llu rows written of %llu", (unsigned long long)written, (unsigned long long)n);
            status = RAD_ERR_INVALID;
        }
    }
    if (status == RAD_OK) {
        ff_comm_gather_u64v(o->comm, o->row_numbers, o->checksum_count, numbers, 0);
        for (uint64_t k = 0; root && k < n; k++) assert(numbers[k] < n);
        if (o->format == FF_FORMAT_SPARSE) {
            gather_by_row(o, o->row_offsets, numbers, gathered, all);
            if (root) all[n] = o->appended;
            gather_by_row(o, o->row_checksums, numbers, gathered, root ? all + n + 1 : NULL);
        } else {
            gather_by_row(o, o->row_checksums, numbers, gathered, all);
        }
        rad_status local = root ? write_prologue(o, all) : RAD_OK;
        status = ff_comm_agree(o->comm, local);
    }
    o->written.seconds = ff_writer_seconds(o->writer);
    o->written.bytes = ff_writer_bytes(o->writer);
    o->written.method = ff_writer_method_name(o->writer);
    rad_status closed = ff_writer_close(o->writer);
    o->writer = NULL;
    if (status == RAD_OK) status = closed;
    free(all);
    free(numbers);
    free(gathered);
    return ff_comm_agree(o->comm, status);
}

ff_output_write_stats ff_output_written(const ff_output *o) { return o->written; }

rad_status ff_output_commit(ff_output *o, rad_status status)
{
    status = ff_comm_agree(o->comm, status);
    if (ff_comm_rank(o->comm) == 0 && !o->handoff) {
        if (status == RAD_OK)
            status = rad_fs_commit(o->temp, o->path);
        else
            rad_fs_discard(o->temp);
    }
    status = ff_comm_agree(o->comm, status);
    if (ff_comm_rank(o->comm) != 0 && !o->handoff) rad_fs_unguard(o->temp);
    output_free(o);
    return status;
}
