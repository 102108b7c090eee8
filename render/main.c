/* render - draws a solved radiosity file into a PNG or EXR image.
 *
 * Parses the command line (cli.h), runs the stage (stage.h) and exits:
 * the only file of this stage that exits or prints outside the logger
 * (--help, --version). See docs/render.md.
 */
#include <stdio.h>

#include "cli.h"
#include "rad_log.h"
#include "stage.h"

int main(int argc, char **argv)
{
    rad_log_set_program("render");
    render_cli cli;
    rad_status status = render_cli_parse(argc, argv, &cli);
    if (status != RAD_OK) {
        fputs("try 'render --help'\n", stderr);
        return rad_status_exit_code(status);
    }
    if (cli.version) {
        printf("render %s\n", RAD_VERSION);
        return 0;
    }
    if (cli.help) {
        fputs(render_cli_usage, stdout);
        return 0;
    }
    if (cli.quiet) rad_log_set_level(RAD_LOG_ERROR);
    return rad_status_exit_code(render_stage_run(&cli.options));
}
