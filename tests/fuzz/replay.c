/* replay.c - runs a fuzz target on files, without libFuzzer.
 *
 *     replay_scene tests/fuzz/regressions/scene [more files or folders]
 *
 * Links with one fuzz_*.c and calls its LLVMFuzzerTestOneInput once per
 * file (folders: every regular file in them, in name order). A crash,
 * sanitizer report or violated invariant aborts; otherwise it exits 0 and
 * says how many inputs it ran. This is how every input that once crashed
 * a fuzzer stays a test in normal CI (and under ASan/UBSan in the
 * sanitized pass).
 */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        perror(path);
        return 1;
    }
    size_t cap = 1 << 16, size = 0;
    uint8_t *data = malloc(cap);
    for (;;) {
        if (!data) {
            fprintf(stderr, "%s: out of memory\n", path);
            fclose(f);
            return 1;
        }
        size += fread(data + size, 1, cap - size, f);
        if (size < cap) break;
        uint8_t *grown = realloc(data, 2 * cap);
        if (!grown) free(data);
        data = grown;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        fprintf(stderr, "%s: read error\n", path);
        free(data);
        return 1;
    }
    /* An exact-size copy, so that ASan sees a read past the input. */
    uint8_t *exact = malloc(size ? size : 1);
    if (exact && size) memcpy(exact, data, size);
    free(data);
    if (!exact) return 1;
    LLVMFuzzerTestOneInput(exact, size);
    free(exact);
    return 0;
}

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

int main(int argc, char **argv)
{
    int failures = 0, inputs = 0;
    for (int a = 1; a < argc; a++) {
        struct stat st;
        if (stat(argv[a], &st) != 0) {
            perror(argv[a]);
            failures++;
            continue;
        }
        if (!S_ISDIR(st.st_mode)) {
            failures += run_file(argv[a]);
            inputs++;
            continue;
        }
        DIR *dir = opendir(argv[a]);
        if (!dir) {
            perror(argv[a]);
            failures++;
            continue;
        }
        char **names = NULL;
        size_t count = 0;
        for (struct dirent *e; (e = readdir(dir));) {
            if (e->d_name[0] == '.') continue; /* ., .., .gitkeep */
            char **grown = realloc(names, (count + 1) * sizeof *names);
            if (!grown) break;
            names = grown;
            size_t len = strlen(argv[a]) + strlen(e->d_name) + 2;
            names[count] = malloc(len);
            if (!names[count]) break;
            snprintf(names[count++], len, "%s/%s", argv[a], e->d_name);
        }
        closedir(dir);
        if (count) qsort(names, count, sizeof *names, by_name);
        for (size_t i = 0; i < count; i++) {
            if (stat(names[i], &st) == 0 && S_ISREG(st.st_mode)) {
                failures += run_file(names[i]);
                inputs++;
            }
            free(names[i]);
        }
        free(names);
    }
    printf("replay: %d input(s), %d could not be read\n", inputs, failures);
    return failures ? 1 : 0;
}
