/* rad_json.c - the streaming JSON writer (rad_json.h). */
#include "rad_json.h"

#include <assert.h>
#include <inttypes.h>
#include <math.h>
#include <string.h>

#include "rad_log.h"

/* Room for any number this file prints: %.17f of 1.8e308 is 327 bytes. */
#define RAD_JSON_NUMBER_MAX 400
#define RAD_JSON_INDENT_MAX 128 /* deeper indentation is written in pieces */

static void writer_init(rad_json_writer *w)
{
    memset(w, 0, sizeof *w);
    w->status = RAD_OK;
}

void rad_json_writer_init_file(rad_json_writer *w, FILE *f)
{
    assert(f);
    writer_init(w);
    w->file = f;
}

void rad_json_writer_init_buffer(rad_json_writer *w, char *buffer, size_t size)
{
    assert(buffer && size >= 1);
    writer_init(w);
    w->buffer = buffer;
    w->buffer_size = size;
    buffer[0] = 0;
}

/* ---- bytes out ---- */

static void put_bytes(rad_json_writer *w, const char *bytes, size_t n)
{
    if (w->status != RAD_OK || n == 0) return;
    if (w->file) {
        if (fwrite(bytes, 1, n, w->file) != n) w->status = RAD_ERR_IO;
    } else {
        /* Copy what fits before the NUL; count everything. */
        if (w->length < w->buffer_size - 1) {
            size_t room = w->buffer_size - 1 - w->length;
            memcpy(w->buffer + w->length, bytes, n < room ? n : room);
            w->buffer[w->length + (n < room ? n : room)] = 0;
        }
    }
    w->length += n;
}

static void put_text(rad_json_writer *w, const char *text)
{
    put_bytes(w, text, strlen(text));
}

static void put_newline_indent(rad_json_writer *w, int spaces)
{
    static const char blanks[RAD_JSON_INDENT_MAX + 1] =
        "                                                                "
        "                                                                ";
    put_bytes(w, "\n", 1);
    while (spaces > 0) {
        int n = spaces < RAD_JSON_INDENT_MAX ? spaces : RAD_JSON_INDENT_MAX;
        put_bytes(w, blanks, (size_t)n);
        spaces -= n;
    }
}

/* ---- strings ---- */

/* Length of the valid UTF-8 sequence at s (s[0] >= 0x80), or 0 if the byte
 * at s starts none. Unicode 15, table 3-7: no overlong forms, no
 * surrogates, nothing beyond U+10FFFF. */
static size_t utf8_sequence_length(const unsigned char *s)
{
    unsigned char c = s[0];
    size_t n;
    unsigned char lo = 0x80, hi = 0xBF; /* bounds of the second byte */
    if (c >= 0xC2 && c <= 0xDF) n = 2;
    else if (c == 0xE0) n = 3, lo = 0xA0;
    else if (c >= 0xE1 && c <= 0xEC) n = 3;
    else if (c == 0xED) n = 3, hi = 0x9F;
    else if (c >= 0xEE && c <= 0xEF) n = 3;
    else if (c == 0xF0) n = 4, lo = 0x90;
    else if (c >= 0xF1 && c <= 0xF3) n = 4;
    else if (c == 0xF4) n = 4, hi = 0x8F;
    else return 0;
    if (s[1] < lo || s[1] > hi) return 0; /* also stops at the NUL */
    for (size_t k = 2; k < n; k++)
        if (s[k] < 0x80 || s[k] > 0xBF) return 0;
    return n;
}

static void put_escaped(rad_json_writer *w, const char *text)
{
    const unsigned char *s = (const unsigned char *)text;
    put_bytes(w, "\"", 1);
    while (*s) {
        /* The run of bytes that need no escape goes out in one piece. */
        const unsigned char *run = s;
        for (;;) {
            if (*s >= 0x20 && *s < 0x80 && *s != '"' && *s != '\\') {
                s++;
            } else if (*s >= 0x80) {
                size_t n = utf8_sequence_length(s);
                if (n == 0) break;
                s += n;
            } else {
                break;
            }
        }
        put_bytes(w, (const char *)run, (size_t)(s - run));
        if (!*s) break;
        char escape[8];
        if (*s == '"' || *s == '\\') {
            escape[0] = '\\';
            escape[1] = (char)*s;
            put_bytes(w, escape, 2);
        } else if (*s < 0x20) {
            snprintf(escape, sizeof escape, "\\u%04x", (unsigned)*s);
            put_bytes(w, escape, 6);
        } else {
            put_bytes(w, "\\ufffd", 6); /* a byte that is not valid UTF-8 */
        }
        s++;
    }
    put_bytes(w, "\"", 1);
}

/* ---- structure ---- */

static int block_count(const rad_json_writer *w, int depth)
{
    int blocks = 0;
    for (int d = 0; d < depth; d++) blocks += w->frames[d].layout == RAD_JSON_BLOCK;
    return blocks;
}

/* What goes before every element (a value in an array, a key in an
 * object): the comma, and the line break with its indentation or a space. */
static void begin_element(rad_json_writer *w, int is_key)
{
    if (w->depth == 0) {
        assert(!w->done && "a second top-level value");
        assert(!is_key && "a key outside any object");
        return;
    }
    rad_json_frame *frame = &w->frames[w->depth - 1];
    if (frame->is_object && !is_key) {
        assert(w->key_pending && "an object member needs its key first");
        w->key_pending = 0;
        return; /* the value after its key */
    }
    assert(!(frame->is_object && w->key_pending) && "a key after a key");
    assert(!(!frame->is_object && is_key) && "a key in an array");
    if (frame->count > 0) put_bytes(w, ",", 1);
    int blocks = block_count(w, w->depth);
    if (frame->layout == RAD_JSON_BLOCK) {
        if (frame->in_line && frame->line_count > 0 && !w->break_pending)
            put_bytes(w, " ", 1);
        else
            put_newline_indent(w, 2 * blocks);
    } else if (w->break_pending) {
        put_newline_indent(w, 2 * blocks + 2 * (w->depth - blocks) - 1);
    } else if (frame->count > 0) {
        put_bytes(w, " ", 1);
    }
    w->break_pending = 0;
    frame->count++;
    if (frame->in_line) frame->line_count++;
}

/* After a complete value: the top-level one ends the document. */
static void end_value(rad_json_writer *w)
{
    if (w->depth == 0) w->done = 1;
}

static void begin_container(rad_json_writer *w, int is_object, rad_json_layout layout)
{
    begin_element(w, 0);
    assert(w->depth < RAD_JSON_MAX_DEPTH && "nested deeper than RAD_JSON_MAX_DEPTH");
    rad_json_frame *frame = &w->frames[w->depth++];
    memset(frame, 0, sizeof *frame);
    frame->is_object = (unsigned char)is_object;
    frame->layout = (unsigned char)layout;
    put_bytes(w, is_object ? "{" : "[", 1);
}

static void end_container(rad_json_writer *w, int is_object)
{
    assert(w->depth > 0 && "an end without its begin");
    rad_json_frame *frame = &w->frames[w->depth - 1];
    assert(frame->is_object == is_object && "an end that does not match its begin");
    assert(!w->key_pending && "a key without its value");
    if (frame->layout == RAD_JSON_BLOCK && frame->count > 0)
        put_newline_indent(w, 2 * block_count(w, w->depth - 1));
    put_bytes(w, is_object ? "}" : "]", 1);
    w->depth--;
    w->break_pending = 0;
    end_value(w);
}

void rad_json_begin_object(rad_json_writer *w, rad_json_layout layout) { begin_container(w, 1, layout); }
void rad_json_end_object(rad_json_writer *w) { end_container(w, 1); }
void rad_json_begin_array(rad_json_writer *w, rad_json_layout layout) { begin_container(w, 0, layout); }
void rad_json_end_array(rad_json_writer *w) { end_container(w, 0); }

void rad_json_key(rad_json_writer *w, const char *key)
{
    assert(key);
    assert(w->depth > 0 && w->frames[w->depth - 1].is_object && "a key outside any object");
    begin_element(w, 1);
    put_escaped(w, key);
    put_bytes(w, ": ", 2);
    w->key_pending = 1;
}

/* ---- values ---- */

static void put_scalar(rad_json_writer *w, const char *text)
{
    begin_element(w, 0);
    put_text(w, text);
    end_value(w);
}

void rad_json_string(rad_json_writer *w, const char *text)
{
    if (!text) {
        rad_json_null(w);
        return;
    }
    begin_element(w, 0);
    put_escaped(w, text);
    end_value(w);
}

void rad_json_number(rad_json_writer *w, double value)
{
    rad_json_number_digits(w, value, 17);
}

/* A finite number as %.*g or %.*f, else null. */
static void put_number(rad_json_writer *w, double value, int fixed, int precision)
{
    char text[RAD_JSON_NUMBER_MAX];
    if (isfinite(value))
        snprintf(text, sizeof text, fixed ? "%.*f" : "%.*g", precision, value);
    else
        snprintf(text, sizeof text, "null");
    put_scalar(w, text);
}

void rad_json_number_digits(rad_json_writer *w, double value, int significant_digits)
{
    assert(significant_digits >= 1 && significant_digits <= 17);
    put_number(w, value, 0, significant_digits);
}

void rad_json_number_fixed(rad_json_writer *w, double value, int decimals)
{
    assert(decimals >= 0 && decimals <= 17);
    put_number(w, value, 1, decimals);
}

void rad_json_int(rad_json_writer *w, int64_t value)
{
    char text[32];
    snprintf(text, sizeof text, "%" PRId64, value);
    put_scalar(w, text);
}

void rad_json_uint(rad_json_writer *w, uint64_t value)
{
    char text[32];
    snprintf(text, sizeof text, "%" PRIu64, value);
    put_scalar(w, text);
}

void rad_json_bool(rad_json_writer *w, int value)
{
    put_scalar(w, value ? "true" : "false");
}

void rad_json_null(rad_json_writer *w)
{
    put_scalar(w, "null");
}

/* ---- layout requests ---- */

void rad_json_line_begin(rad_json_writer *w)
{
    assert(w->depth > 0);
    rad_json_frame *frame = &w->frames[w->depth - 1];
    assert(!frame->in_line && "rad_json_line_begin twice");
    frame->in_line = 1;
    frame->line_count = 0;
}

void rad_json_line_end(rad_json_writer *w)
{
    assert(w->depth > 0);
    rad_json_frame *frame = &w->frames[w->depth - 1];
    assert(frame->in_line && "rad_json_line_end without its begin");
    frame->in_line = 0;
}

void rad_json_line_break(rad_json_writer *w)
{
    assert(w->depth > 0);
    w->break_pending = 1;
}

rad_status rad_json_finish(rad_json_writer *w)
{
    assert(w->done && w->depth == 0 && "the document is not complete");
    put_bytes(w, "\n", 1);
    if (w->status == RAD_OK && !w->file && w->length >= w->buffer_size) {
        rad_error("JSON document of %zu bytes does not fit its buffer of %zu", w->length, w->buffer_size - 1);
        w->status = RAD_ERR_NOMEM;
    }
    return w->status;
}

size_t rad_json_length(const rad_json_writer *w)
{
    return w->length;
}
