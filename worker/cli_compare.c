/* Placeholder until the 'compare' command lands; replaced by its implementation. */
#include "pf_cli.h"

int pf_cli_compare(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    return pf_cli_fail("compare", 1, "not built yet");
}
