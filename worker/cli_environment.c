/*
 * The one place where environment variables become Vulkan options (core/
 * reads no environment, so a library user gets exactly what it asks for):
 * $PHOTONFARM_DEVICE stands in for a missing --device, and $PF_VK_VALIDATION
 * (unset, empty or "0": off) turns the validation layer on for every
 * command, which is how the test suite runs the CLI with validation;
 * $PHOTONFARM_WORKER_NAME stands in for a missing worker --name (a container
 * is configured by its environment).
 */
#include "pf_cli.h"

#include <stdlib.h>
#include <string.h>

pf_vk_options pf_cli_vk_options(const char *device_option, const char *cache_dir)
{
    const char *validation = getenv("PF_VK_VALIDATION");
    pf_vk_options options = {0};
    options.device_selector = device_option ? device_option : getenv("PHOTONFARM_DEVICE");
    options.validation = validation && validation[0] && strcmp(validation, "0") != 0;
    options.pipeline_cache_dir = cache_dir;
    return options;
}

const char *pf_cli_worker_name(const char *name_option)
{
    const char *name = name_option ? name_option : getenv("PHOTONFARM_WORKER_NAME");
    return name && *name ? name : NULL;
}
