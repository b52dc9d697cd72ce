/* The version string of this build (pf_cli.h), from the generated header. */
#include "pf_cli.h"
#include "pf_version_info.h"

const char *pf_version_string(void)
{
    return PF_VERSION "+" PF_GIT_REVISION;
}
