/* test_fs.c - the file policy of core/rad_fs (issue 16): temporaries made
 * exclusively and never through a planted name, removed on every
 * catchable termination signal; outputs that are devices written in
 * place; outputs of the wrong kind and aliased roles refused; inputs that
 * are not regular files refused without blocking.
 *
 * usage: test_fs [DIR]   (default: a new directory under /tmp)
 */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include "rad_fs.h"
#include "rad_test.h"

static char g_dir[512];

static const char *in_dir(const char *name)
{
    static char path[4][1024];
    static int k;
    k = (k + 1) % 4;
    snprintf(path[k], sizeof path[k], "%s/%s", g_dir, name);
    return path[k];
}

/* Files in g_dir whose names start with prefix. */
static int count_prefixed(const char *prefix)
{
    DIR *d = opendir(g_dir);
    int n = 0;
    for (struct dirent *e; d && (e = readdir(d));) n += !strncmp(e->d_name, prefix, strlen(prefix));
    if (d) closedir(d);
    return n;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    RAD_CHECK(f && fputs(text, f) >= 0 && fclose(f) == 0);
}

static int has_text(const char *path, const char *text)
{
    char buf[256] = {0};
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    return !strcmp(buf, text);
}

/* A temporary is new, random, exclusive; commit renames it, discard removes
 * it; a symlink planted beside the output is never written through. */
static void test_temporaries(void)
{
    const char *out = in_dir("out.txt"), *victim = in_dir("victim.txt");
    write_text(out, "old");
    write_text(victim, "precious");
    /* The old predictable names, planted as symlinks to the victim. */
    char planted[1100];
    snprintf(planted, sizeof planted, "%s.tmp-%ld", out, (long)getpid());
    unlink(planted);
    RAD_CHECK(symlink("victim.txt", planted) == 0);
    char temp[1100], temp2[1100];
    RAD_CHECK(rad_fs_temp_create(out, temp, sizeof temp) == RAD_OK);
    RAD_CHECK(rad_fs_temp_create(out, temp2, sizeof temp2) == RAD_OK);
    RAD_CHECK(strcmp(temp, temp2) && strcmp(temp, planted) && strncmp(temp, out, strlen(out)) == 0);
    struct stat st;
    RAD_CHECK(lstat(temp, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 0);
    /* O_NOFOLLOW: a temporary replaced by a symlink is not opened through. */
    RAD_CHECK(unlink(temp2) == 0 && symlink("victim.txt", temp2) == 0);
    errno = 0;
    RAD_CHECK(rad_fs_temp_open(temp2) == NULL && errno == ELOOP);
    unlink(temp2);
    rad_fs_unguard(temp2);
    FILE *f = rad_fs_temp_open(temp);
    RAD_CHECK(f && fputs("new", f) >= 0 && fclose(f) == 0);
    RAD_CHECK(rad_fs_commit(temp, out) == RAD_OK && has_text(out, "new") && access(temp, F_OK) != 0);
    RAD_CHECK(has_text(victim, "precious"));
    /* discard removes only what this process made. */
    RAD_CHECK(rad_fs_temp_create(out, temp, sizeof temp) == RAD_OK);
    rad_fs_discard(temp);
    RAD_CHECK(access(temp, F_OK) != 0);
    rad_fs_discard(victim); /* not ours: untouched */
    RAD_CHECK(has_text(victim, "precious"));
    unlink(planted);
}

/* Each catchable termination signal, in a child holding a temporary:
 * the child dies of it and the temporary is gone, the output untouched. */
static void test_signals(void)
{
    static const int sigs[] = {SIGTERM, SIGINT, SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2,
                               SIGALRM, SIGPIPE, SIGXCPU, SIGXFSZ, SIGVTALRM, SIGPROF};
    const char *out = in_dir("sig.txt");
    for (size_t k = 0; k < sizeof sigs / sizeof sigs[0]; k++) {
        write_text(out, "old");
        pid_t child = fork();
        if (child == 0) {
            char temp[1100];
            if (rad_fs_temp_create(out, temp, sizeof temp) != RAD_OK) _exit(3);
            FILE *f = rad_fs_temp_open(temp);
            if (!f || fputs("half", f) < 0 || fflush(f) != 0) _exit(4);
            kill(getpid(), sigs[k]);
            _exit(5); /* not reached */
        }
        int status = 0;
        RAD_CHECK(waitpid(child, &status, 0) == child);
        RAD_CHECK(WIFSIGNALED(status) && WTERMSIG(status) == sigs[k]);
        RAD_CHECK(count_prefixed("sig.txt.tmp-") == 0);
        RAD_CHECK(has_text(out, "old"));
        if (!(WIFSIGNALED(status) && WTERMSIG(status) == sigs[k]))
            fprintf(stderr, "signal %s: child status %d\n", strsignal(sigs[k]), status);
    }
}

/* Outputs: new, regular or character devices; a device is written in place. */
static void test_outputs(void)
{
    rad_test_capture_log();
    RAD_CHECK(rad_fs_check_output("-o", "") == RAD_ERR_USAGE && rad_test_log_contains("-o: empty file name"));
    RAD_CHECK(rad_fs_check_output("-o", g_dir) == RAD_ERR_USAGE && rad_test_log_contains("is a directory"));
    const char *fifo = in_dir("fifo");
    unlink(fifo);
    RAD_CHECK(mkfifo(fifo, 0600) == 0);
    RAD_CHECK(rad_fs_check_output("-o", fifo) == RAD_ERR_USAGE && rad_test_log_contains("is a FIFO"));
    RAD_CHECK(rad_fs_check_output("-o", in_dir("new.txt")) == RAD_OK);
    /* A new file's folder is checked up front (a late output must not fail
     * after an earlier one replaced its file). */
    RAD_CHECK(rad_fs_check_output("--stats", in_dir("no/such/s.json")) == RAD_ERR_USAGE &&
              rad_test_log_contains("--stats: ") && rad_test_log_contains("no/such/s.json: cannot write"));
    RAD_CHECK(rad_fs_check_output("-o", "/dev/null/x") == RAD_ERR_USAGE && rad_test_log_contains("not a folder"));
    RAD_CHECK(rad_fs_check_output("-o", "/dev/null") == RAD_OK);
    rad_log_set_sink(NULL, NULL);
    /* /dev/null stays a device: written in place, never renamed over. */
    char temp[1100];
    RAD_CHECK(rad_fs_temp_create("/dev/null", temp, sizeof temp) == RAD_OK && !strcmp(temp, "/dev/null"));
    FILE *f = rad_fs_temp_open(temp);
    RAD_CHECK(f && fputs("x", f) >= 0 && fclose(f) == 0);
    RAD_CHECK(rad_fs_commit(temp, "/dev/null") == RAD_OK);
    rad_fs_discard("/dev/null");
    struct stat st;
    RAD_CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode));
    /* A private copy of /dev/null (root only: mknod). */
    const char *node = in_dir("null-copy");
    unlink(node);
    if (mknod(node, S_IFCHR | 0666, makedev(1, 3)) == 0) {
        RAD_CHECK(rad_fs_temp_create(node, temp, sizeof temp) == RAD_OK && !strcmp(temp, node));
        RAD_CHECK(rad_fs_commit(temp, node) == RAD_OK);
        RAD_CHECK(stat(node, &st) == 0 && S_ISCHR(st.st_mode));
        unlink(node);
    } else {
        printf("mknod not permitted here (%s): private device copy not tested\n", strerror(errno));
    }
    unlink(fifo);
}

/* Two roles naming one file. */
static void test_roles(void)
{
    const char *a = in_dir("a.obj"), *soft = in_dir("link.obj"), *hard = in_dir("hard.obj");
    write_text(a, "v 0 0 0\n");
    unlink(soft); /* a run before */
    unlink(hard);
    RAD_CHECK(symlink("a.obj", soft) == 0 && link(a, hard) == 0); /* relative to its folder */
    char dotted[1100];
    snprintf(dotted, sizeof dotted, "%s/./b.out", g_dir);
    rad_test_capture_log();
    rad_fs_role same_out[] = {{"-o", in_dir("b.out"), 1}, {"--stats", dotted, 1}};
    RAD_CHECK(rad_fs_check_roles(same_out, 2) == RAD_ERR_USAGE &&
              rad_test_log_contains("-o and --stats name the same file"));
    rad_fs_role via_link[] = {{"the scene", soft, 0}, {"-o", a, 1}};
    RAD_CHECK(rad_fs_check_roles(via_link, 2) == RAD_ERR_USAGE &&
              rad_test_log_contains("the output would overwrite the input"));
    rad_fs_role via_hard[] = {{"the scene", hard, 0}, {"-o", a, 1}};
    RAD_CHECK(rad_fs_check_roles(via_hard, 2) == RAD_ERR_USAGE);
    rad_fs_role two_inputs[] = {{"the scene", a, 0}, {"--camera", hard, 0}}; /* reading twice is fine */
    RAD_CHECK(rad_fs_check_roles(two_inputs, 2) == RAD_OK);
    rad_fs_role devices[] = {{"-o", "/dev/null", 1}, {"--stats", "/dev/null", 1}};
    RAD_CHECK(rad_fs_check_roles(devices, 2) == RAD_OK);
    rad_fs_role distinct[] = {{"-o", in_dir("c.out"), 1}, {"--stats", in_dir("c.json"), 1}, {"x", NULL, 1}};
    RAD_CHECK(rad_fs_check_roles(distinct, 3) == RAD_OK);
    rad_log_set_sink(NULL, NULL);
    unlink(soft);
    unlink(hard);
    unlink(a);
}

/* Inputs: regular files only, a FIFO refused without hanging. */
static void test_inputs(void)
{
    const char *fifo = in_dir("in-fifo");
    unlink(fifo);
    RAD_CHECK(mkfifo(fifo, 0600) == 0);
    rad_test_capture_log();
    char *data = NULL;
    size_t size = 0;
    RAD_CHECK(rad_fs_read_all(fifo, &data, &size) == RAD_ERR_IO && rad_test_log_contains("is a FIFO"));
    RAD_CHECK(rad_fs_read_all("/dev/zero", &data, &size) == RAD_ERR_IO &&
              rad_test_log_contains("/dev/zero: is a character device; inputs are regular files"));
    RAD_CHECK(rad_fs_read_all(g_dir, &data, &size) == RAD_ERR_IO && rad_test_log_contains("is a directory"));
    RAD_CHECK(rad_fs_open_input(g_dir) == NULL);
    rad_log_set_sink(NULL, NULL);
    unlink(fifo);
}

int main(int argc, char **argv)
{
    if (argc > 1) {
        snprintf(g_dir, sizeof g_dir, "%s", argv[1]);
        mkdir(g_dir, 0700);
    } else {
        snprintf(g_dir, sizeof g_dir, "/tmp/test_fs.XXXXXX");
        if (!mkdtemp(g_dir)) return 1;
    }
    test_temporaries();
    test_signals();
    test_outputs();
    test_roles();
    test_inputs();
    return rad_test_finish();
}
