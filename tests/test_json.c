/* test_json.c - tests of core/rad_json: exact output for layouts and
 * nesting, string escaping (quotes, backslash, control characters, UTF-8
 * valid and not), numbers (integers, round trips through strtod, non-finite
 * as null, negative zero), empty containers, a buffer too small, files. */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rad_json.h"
#include "rad_test.h"

static char text[8192];

static void start(rad_json_writer *w)
{
    rad_json_writer_init_buffer(w, text, sizeof text);
}

/* Finishes w and checks the whole document against want. */
#define CHECK_DOCUMENT(w, want)                                                         \
    do {                                                                                \
        RAD_CHECK(rad_json_finish(w) == RAD_OK);                                        \
        if (strcmp(text, want) != 0)                                                    \
            fprintf(stderr, "%s:%d: got\n%s--- expected\n%s---\n", __FILE__, __LINE__, \
                    text, want);                                                        \
        RAD_CHECK(strcmp(text, want) == 0);                                             \
        RAD_CHECK(rad_json_length(w) == strlen(want));                                  \
    } while (0)

static void test_empty_containers(void)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_end_object(&w);
    CHECK_DOCUMENT(&w, "{}\n");

    start(&w);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_end_array(&w);
    CHECK_DOCUMENT(&w, "[]\n");

    start(&w);
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_key(&w, "a");
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_end_object(&w);
    rad_json_key(&w, "b");
    rad_json_begin_array(&w, RAD_JSON_BLOCK);
    rad_json_end_array(&w);
    rad_json_key(&w, "c");
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_end_array(&w);
    rad_json_end_object(&w);
    CHECK_DOCUMENT(&w, "{\n  \"a\": {},\n  \"b\": [],\n  \"c\": []\n}\n");
}

static void test_nesting(void)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_key(&w, "name");
    rad_json_string(&w, "box");
    rad_json_key(&w, "list");
    rad_json_begin_array(&w, RAD_JSON_BLOCK);
    rad_json_int(&w, 1);
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "x");
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_int(&w, 1);
    rad_json_int(&w, 2);
    rad_json_end_array(&w);
    rad_json_key(&w, "y");
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "z");
    rad_json_null(&w);
    rad_json_end_object(&w);
    rad_json_end_object(&w);
    rad_json_begin_array(&w, RAD_JSON_BLOCK);
    rad_json_bool(&w, 1);
    rad_json_bool(&w, 0);
    rad_json_end_array(&w);
    rad_json_end_array(&w);
    rad_json_key(&w, "last");
    rad_json_string(&w, NULL);
    rad_json_end_object(&w);
    CHECK_DOCUMENT(&w, "{\n"
                       "  \"name\": \"box\",\n"
                       "  \"list\": [\n"
                       "    1,\n"
                       "    {\"x\": [1, 2], \"y\": {\"z\": null}},\n"
                       "    [\n"
                       "      true,\n"
                       "      false\n"
                       "    ]\n"
                       "  ],\n"
                       "  \"last\": null\n"
                       "}\n");

    /* A top-level scalar is a document too. */
    start(&w);
    rad_json_string(&w, "alone");
    CHECK_DOCUMENT(&w, "\"alone\"\n");

    /* As deep as the writer allows. */
    start(&w);
    for (int d = 0; d < RAD_JSON_MAX_DEPTH; d++) rad_json_begin_array(&w, RAD_JSON_INLINE);
    for (int d = 0; d < RAD_JSON_MAX_DEPTH; d++) rad_json_end_array(&w);
    char want[2 * RAD_JSON_MAX_DEPTH + 2];
    for (int d = 0; d < RAD_JSON_MAX_DEPTH; d++) {
        want[d] = '[';
        want[2 * RAD_JSON_MAX_DEPTH - 1 - d] = ']';
    }
    snprintf(want + 2 * RAD_JSON_MAX_DEPTH, 2, "\n");
    CHECK_DOCUMENT(&w, want);
}

/* rad_json_line_begin/_end and rad_json_line_break, as the stats files
 * use them: members sharing a line in a block object, continuation lines
 * in inline containers (one column past the element, two more per level). */
static void test_lines(void)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_object(&w, RAD_JSON_BLOCK);
    rad_json_key(&w, "a");
    rad_json_int(&w, 1);
    rad_json_line_begin(&w);
    rad_json_key(&w, "b");
    rad_json_int(&w, 2);
    rad_json_key(&w, "c");
    rad_json_int(&w, 3);
    rad_json_line_end(&w);
    rad_json_key(&w, "list");
    rad_json_begin_array(&w, RAD_JSON_BLOCK);
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_line_begin(&w); /* no effect in an inline object */
    rad_json_key(&w, "d");
    rad_json_int(&w, 4);
    rad_json_line_end(&w);
    rad_json_line_break(&w);
    rad_json_key(&w, "h");
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    for (int k = 0; k < 5; k++) {
        if (k == 3) rad_json_line_break(&w);
        rad_json_int(&w, k);
    }
    rad_json_end_array(&w);
    rad_json_end_object(&w);
    rad_json_end_array(&w);
    rad_json_end_object(&w);
    CHECK_DOCUMENT(&w, "{\n"
                       "  \"a\": 1,\n"
                       "  \"b\": 2, \"c\": 3,\n"
                       "  \"list\": [\n"
                       "    {\"d\": 4,\n"
                       "     \"h\": [0, 1, 2,\n"
                       "       3, 4]}\n"
                       "  ]\n"
                       "}\n");
}

static void test_strings(void)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_array(&w, RAD_JSON_BLOCK);
    rad_json_string(&w, "");
    rad_json_string(&w, "say \"hi\"");
    rad_json_string(&w, "C:\\dir\\file");
    rad_json_string(&w, "\x01\b\t\n\f\r\x1f end");
    rad_json_string(&w, "del \x7f / slash");
    /* Valid UTF-8 of 2, 3 and 4 bytes, and the limits U+FFFF, U+10FFFF. */
    rad_json_string(&w, "\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80 \xef\xbf\xbf \xf4\x8f\xbf\xbf");
    /* Not UTF-8: a stray continuation byte, 0xFF, an overlong '/', a
     * surrogate (U+D800), beyond U+10FFFF, a sequence cut short. */
    rad_json_string(&w, "a\x80" "b\xff" "c\xc0\xaf" "d\xed\xa0\x80" "e\xf4\x90\x80\x80" "f\xe2\x82");
    rad_json_end_array(&w);
    CHECK_DOCUMENT(&w, "[\n"
                       "  \"\",\n"
                       "  \"say \\\"hi\\\"\",\n"
                       "  \"C:\\\\dir\\\\file\",\n"
                       "  \"\\u0001\\u0008\\u0009\\u000a\\u000c\\u000d\\u001f end\",\n"
                       "  \"del \x7f / slash\",\n"
                       "  \"\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80 \xef\xbf\xbf \xf4\x8f\xbf\xbf\",\n"
                       "  \"a\\ufffdb\\ufffdc\\ufffd\\ufffdd\\ufffd\\ufffd\\ufffde\\ufffd\\ufffd\\ufffd\\ufffdf"
                       "\\ufffd\\ufffd\"\n"
                       "]\n");

    /* Keys are escaped alike. */
    start(&w);
    rad_json_begin_object(&w, RAD_JSON_INLINE);
    rad_json_key(&w, "k\"\\\n");
    rad_json_int(&w, 0);
    rad_json_end_object(&w);
    CHECK_DOCUMENT(&w, "{\"k\\\"\\\\\\u000a\": 0}\n");
}

/* The number text between "[" and "]" of a one-number document. */
static double read_back(const char *document)
{
    char *end = NULL;
    double v = strtod(document + 1, &end);
    RAD_CHECK(end && *end == ']');
    return v;
}

static const char *number_text(double v)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_number(&w, v);
    rad_json_end_array(&w);
    RAD_CHECK(rad_json_finish(&w) == RAD_OK);
    return text;
}

static void test_numbers(void)
{
    rad_json_writer w;
    start(&w);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_int(&w, 0);
    rad_json_int(&w, -42);
    rad_json_int(&w, INT64_MIN);
    rad_json_int(&w, INT64_MAX);
    rad_json_uint(&w, UINT64_MAX);
    rad_json_number(&w, 3);
    rad_json_number(&w, 1e22); /* exact in binary: no 17th-digit noise */
    rad_json_number(&w, INFINITY);
    rad_json_number(&w, -INFINITY);
    rad_json_number(&w, NAN);
    rad_json_number(&w, -0.0);
    rad_json_number_digits(&w, 1234567.0, 6);
    rad_json_number_digits(&w, 1.0 / 3, 9);
    rad_json_number_digits(&w, NAN, 6);
    rad_json_number_fixed(&w, 0.0001234, 6);
    rad_json_number_fixed(&w, 2.0 / 3, 6);
    rad_json_number_fixed(&w, -INFINITY, 6);
    rad_json_end_array(&w);
    CHECK_DOCUMENT(&w, "[0, -42, -9223372036854775808, 9223372036854775807, 18446744073709551615, 3, 1e+22, "
                       "null, null, null, -0, 1.23457e+06, 0.333333333, null, 0.000123, 0.666667, null]\n");

    /* 17 significant digits read back through strtod to the same double. */
    const double values[] = {0.1, 1.0 / 3, 2.0 / 3, 1e-10, 6.02214076e23, DBL_MAX, DBL_MIN, 5e-324,
                             -1.0000000000000002, 232050.0, 0.1 + 0.2};
    for (size_t k = 0; k < sizeof values / sizeof values[0]; k++) {
        double back = read_back(number_text(values[k]));
        if (back != values[k]) fprintf(stderr, "%.17g came back as %.17g (%s)\n", values[k], back, text);
        RAD_CHECK(back == values[k]);
    }
    RAD_CHECK(strcmp(number_text(0.1), "[0.10000000000000001]\n") == 0);
    /* Negative zero keeps its sign. */
    double zero = read_back(number_text(-0.0));
    RAD_CHECK(zero == 0.0 && signbit(zero));
}

static void test_small_buffer(void)
{
    rad_test_capture_log();
    char small[8];
    rad_json_writer w;
    rad_json_writer_init_buffer(&w, small, sizeof small);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_string(&w, "longer than eight");
    rad_json_end_array(&w);
    RAD_CHECK(rad_json_finish(&w) == RAD_ERR_NOMEM);
    RAD_CHECK(strcmp(small, "[\"longe") == 0); /* cut short, NUL-terminated */
    RAD_CHECK(rad_json_length(&w) == strlen("[\"longer than eight\"]\n"));
    RAD_CHECK(rad_test_log_contains("does not fit"));

    /* Exactly full: the document and its NUL. */
    char exact[4];
    rad_json_writer_init_buffer(&w, exact, sizeof exact);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_end_array(&w);
    RAD_CHECK(rad_json_finish(&w) == RAD_OK && strcmp(exact, "[]\n") == 0);
    rad_log_set_sink(NULL, NULL);
}

/* The same document into a file as into a buffer; a full disk is an I/O
 * error. */
static void test_file(void)
{
    FILE *f = tmpfile();
    RAD_CHECK(f != NULL);
    if (f) {
        rad_json_writer w;
        rad_json_writer_init_file(&w, f);
        rad_json_begin_object(&w, RAD_JSON_BLOCK);
        rad_json_key(&w, "path");
        rad_json_string(&w, "a\"b\\c\x01\xc3\xa9");
        rad_json_key(&w, "values");
        rad_json_begin_array(&w, RAD_JSON_INLINE);
        rad_json_number(&w, 0.5);
        rad_json_uint(&w, 7);
        rad_json_end_array(&w);
        rad_json_end_object(&w);
        RAD_CHECK(rad_json_finish(&w) == RAD_OK);
        const char *want = "{\n  \"path\": \"a\\\"b\\\\c\\u0001\xc3\xa9\",\n  \"values\": [0.5, 7]\n}\n";
        RAD_CHECK(rad_json_length(&w) == strlen(want));
        char got[256] = "";
        rewind(f);
        size_t n = fread(got, 1, sizeof got - 1, f);
        got[n] = 0;
        RAD_CHECK(strcmp(got, want) == 0);
        fclose(f);
    }
    FILE *full = fopen("/dev/full", "w");
    if (!full) {
        fprintf(stderr, "note: no /dev/full here; the write-error case is not run\n");
        return;
    }
    setvbuf(full, NULL, _IONBF, 0); /* every write reaches the device */
    rad_json_writer w;
    rad_json_writer_init_file(&w, full);
    rad_json_begin_array(&w, RAD_JSON_INLINE);
    rad_json_int(&w, 1);
    rad_json_end_array(&w);
    RAD_CHECK(rad_json_finish(&w) == RAD_ERR_IO);
    RAD_CHECK(ferror(full));
    fclose(full);
}

int main(void)
{
    test_empty_containers();
    test_nesting();
    test_lines();
    test_strings();
    test_numbers();
    test_small_buffer();
    test_file();
    return rad_test_finish();
}
