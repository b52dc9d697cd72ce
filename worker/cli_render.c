/* Placeholder until the 'render' command lands; replaced by its implementation. */
#include "pf_cli.h"

int pf_cli_render(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    return pf_cli_fail("render", 1, "not built yet");
}
