/* test_parse.c - the strict option numbers of core/rad_parse: integers,
 * reals in a range, and sizes in bytes (formfactor --max-bytes). */
#include <stdint.h>

#include "rad_parse.h"
#include "rad_test.h"

static void expect_bytes(const char *text, double want)
{
    double got = -1;
    RAD_CHECK(rad_parse_bytes("--max-bytes", text, &got) == RAD_OK);
    RAD_CHECK(got == want);
}

static void refuse_bytes(const char *text)
{
    double got = -1;
    rad_test_capture_log();
    RAD_CHECK(rad_parse_bytes("--max-bytes", text, &got) == RAD_ERR_USAGE);
    RAD_CHECK(got == -1);
    RAD_CHECK(rad_test_log_contains("--max-bytes: '"));
    RAD_CHECK(rad_test_log_contains("' is not a size in bytes"));
}

int main(void)
{
    expect_bytes("1", 1);
    expect_bytes("1e9", 1e9);
    expect_bytes("50G", 50e9);
    expect_bytes("50GB", 50e9);
    expect_bytes("2GiB", 2147483648.0);
    expect_bytes("1.5Mi", 1572864.0);
    expect_bytes("500k", 5e5);
    expect_bytes("3T", 3e12);
    expect_bytes("8Pi", 8 * 1125899906842624.0);
    const char *bad[] = {"", "0", "0.5", "-1", "+5G", " 5G", "5 G", "5g", "5GiBs", "G", "nan", "inf", "1e99", "5X", "9.3e18"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) refuse_bytes(bad[i]);

    uint64_t u = 0;
    rad_test_capture_log();
    RAD_CHECK(rad_parse_uint("--seed", "18446744073709551615", 0, UINT64_MAX, &u) == RAD_OK && u == UINT64_MAX);
    RAD_CHECK(rad_parse_uint("--seed", "18446744073709551616", 0, UINT64_MAX, &u) == RAD_ERR_USAGE);
    RAD_CHECK(rad_test_log_contains("--seed: '18446744073709551616' is not an integer in [0, 18446744073709551615]"));
    double r = 0;
    RAD_CHECK(rad_parse_real("--clamp-rho", "0.99", 0, 0, 1, 0, &r) == RAD_OK && r == 0.99);
    RAD_CHECK(rad_parse_real("--clamp-rho", "1", 0, 0, 1, 0, &r) == RAD_ERR_USAGE);
    RAD_CHECK(rad_test_log_contains("--clamp-rho: '1' is not a number in (0, 1)"));
    return rad_test_finish();
}
