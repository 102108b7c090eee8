/* cli.h - render's command line: the options into render_options
 * (stage.h), --help and --version.
 *
 *     render_cli cli;
 *     rad_status status = render_cli_parse(argc, argv, &cli); // logs what is wrong
 *     if (status == RAD_OK && cli.help) fputs(render_cli_usage, stdout);
 *
 * getopt_long, as formfactor and solve parse theirs: "--name VALUE",
 * "--name=VALUE", unambiguous abbreviations, "-o VALUE" and "-oVALUE";
 * options and the input in any order.
 */
#ifndef RENDER_CLI_H
#define RENDER_CLI_H

#include "rad_status.h"
#include "stage.h"

typedef struct render_cli {
    render_options options; /* the command line's defaults where not given */
    int quiet;              /* -q: only errors on stderr */
    int help, version;      /* print that and do nothing else */
} render_cli;

/* The --help text. */
extern const char render_cli_usage[];

/* RAD_ERR_USAGE (logged) for an unknown option, a missing or bad value,
 * or two input files; *out is set only on RAD_OK. */
rad_status render_cli_parse(int argc, char **argv, render_cli *out);

#endif
