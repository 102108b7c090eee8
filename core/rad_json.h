/* rad_json.h - the one JSON writer: a small streaming writer for the
 * programs' --stats files.
 *
 *     rad_json_writer w;
 *     rad_json_writer_init_file(&w, f);      // or _init_buffer(&w, text, size)
 *     rad_json_begin_object(&w, RAD_JSON_BLOCK);
 *     rad_json_key(&w, "scene");
 *     rad_json_string(&w, path);
 *     rad_json_key(&w, "time_seconds");
 *     rad_json_begin_object(&w, RAD_JSON_INLINE);
 *     rad_json_key(&w, "total");
 *     rad_json_number_fixed(&w, seconds, 6);
 *     rad_json_end_object(&w);
 *     rad_json_end_object(&w);
 *     rad_status status = rad_json_finish(&w); // the final newline; the first error
 * writes
 *     {
 *       "scene": "room \"A\".obj",
 *       "time_seconds": {"total": 0.012000}
 *     }
 *
 * Layout. A RAD_JSON_BLOCK container puts each element on a line of its
 * own, indented two spaces per block container around it, and its closing
 * bracket on a line of its own; a RAD_JSON_INLINE container keeps its
 * elements on its opening line, ", " between them. Two exceptions, asked
 * for by the caller: rad_json_line_begin/_end keep a run of a block
 * container's elements on one line, and rad_json_line_break starts the next
 * element of an inline container on a continuation line, indented by
 * 2 x (block containers open) + 2 x (inline containers open) - 1 spaces:
 * one column past the block element it belongs to, two more for each
 * further inline level (so it never lines up with a block element).
 * Empty containers are "{}" and "[]".
 *
 * Strings (values and keys) are written as given, bytes of valid UTF-8
 * included, with '"' and '\' escaped, control characters (below 0x20) as
 * \u00XX (lower-case hex), and every byte that is not part of valid UTF-8
 * (stray continuation bytes, overlong forms, surrogates, beyond U+10FFFF,
 * truncated sequences) as \ufffd, so the document is always valid UTF-8.
 *
 * Numbers. JSON has no infinity or NaN: non-finite doubles are written as
 * null. rad_json_number writes 17 significant digits (%.17g, which reads
 * back through strtod to the same double; -0.0 is "-0"); _digits and
 * _fixed write fewer where the value is a measurement (%.*g, %.*f).
 *
 * Misuse - a value where an object expects a key, a key in an array, an
 * end that does not match its begin, nesting deeper than
 * RAD_JSON_MAX_DEPTH, a second top-level value - is a programmer error
 * (assert). Output errors are sticky: after the first, nothing more is
 * written and rad_json_finish returns it.
 */
#ifndef RAD_JSON_H
#define RAD_JSON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rad_status.h"

#define RAD_JSON_MAX_DEPTH 32

typedef enum rad_json_layout {
    RAD_JSON_BLOCK = 0, /* one element per line */
    RAD_JSON_INLINE = 1 /* every element on the opening line */
} rad_json_layout;

/* One open container. Private to rad_json.c. */
typedef struct rad_json_frame {
    unsigned char is_object;
    unsigned char layout;     /* rad_json_layout */
    unsigned char in_line;    /* between rad_json_line_begin and _end */
    uint32_t count;           /* elements written (an object's: members) */
    uint32_t line_count;      /* elements written since rad_json_line_begin */
} rad_json_frame;

/* The writer: fields are private; zero-initialised is not usable, call an
 * init function. It owns nothing (the FILE or buffer stays the caller's). */
typedef struct rad_json_writer {
    FILE *file;               /* NULL: writing into buffer */
    char *buffer;
    size_t buffer_size;
    size_t length;            /* bytes of the document so far (also those past a full buffer) */
    int depth;                /* containers open */
    int key_pending;          /* a key was written; its value is due */
    int break_pending;        /* rad_json_line_break: the next element starts a new line */
    int done;                 /* the top-level value is complete */
    rad_status status;        /* the first output error */
    rad_json_frame frames[RAD_JSON_MAX_DEPTH];
} rad_json_writer;

/* Writes to f (fwrite). A failed write makes the writer's status RAD_ERR_IO
 * without logging: ferror(f) stays set for whoever closes f
 * (rad_fs_close_commit logs it and removes the temporary). */
void rad_json_writer_init_file(rad_json_writer *w, FILE *f);
/* Writes into buffer[0 .. size - 1], always NUL-terminated (size >= 1).
 * A document that does not fit is cut short and rad_json_finish returns
 * RAD_ERR_NOMEM (logged); rad_json_length says how much it needed. */
void rad_json_writer_init_buffer(rad_json_writer *w, char *buffer, size_t size);

void rad_json_begin_object(rad_json_writer *w, rad_json_layout layout);
void rad_json_end_object(rad_json_writer *w);
void rad_json_begin_array(rad_json_writer *w, rad_json_layout layout);
void rad_json_end_array(rad_json_writer *w);

/* The next member's key (escaped as strings are); its value follows. */
void rad_json_key(rad_json_writer *w, const char *key);

/* A string value; NULL writes null (an absent name, such as "no file"). */
void rad_json_string(rad_json_writer *w, const char *text);
/* %.17g: the same double when read back. Non-finite: null. */
void rad_json_number(rad_json_writer *w, double value);
/* %.*g with significant_digits in [1, 17]. Non-finite: null. */
void rad_json_number_digits(rad_json_writer *w, double value, int significant_digits);
/* %.*f with decimals in [0, 17]. Non-finite: null. */
void rad_json_number_fixed(rad_json_writer *w, double value, int decimals);
void rad_json_int(rad_json_writer *w, int64_t value);
void rad_json_uint(rad_json_writer *w, uint64_t value);
void rad_json_bool(rad_json_writer *w, int value); /* nonzero: true */
void rad_json_null(rad_json_writer *w);

/* In a block container: the elements written until rad_json_line_end share
 * one line (the first starts it, as any element would). No effect in an
 * inline container. */
void rad_json_line_begin(rad_json_writer *w);
void rad_json_line_end(rad_json_writer *w);
/* The next element of the current container starts a new line (in an
 * inline container, a continuation line; see Layout above). */
void rad_json_line_break(rad_json_writer *w);

/* Ends the document (asserts that the top-level value is complete) with a
 * newline; returns RAD_OK or the first output error. */
rad_status rad_json_finish(rad_json_writer *w);
/* Bytes of the document written so far, including any that did not fit
 * into the buffer (not counting its NUL). */
size_t rad_json_length(const rad_json_writer *w);

#endif
