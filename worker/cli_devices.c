/* Placeholder until the 'devices' command lands; replaced by its implementation. */
#include "pf_cli.h"

int pf_cli_devices(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    return pf_cli_fail("devices", 1, "not built yet");
}
