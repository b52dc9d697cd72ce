/*
 * The sampling options every preset shares, for render and enqueue (cli_queue.h):
 *   --filter NAME      pixel filter: gaussian (default), box, blackman-harris
 *   --max-bounces N    reference, final: light of at most N bounces (0..1024;
 *                      0 = direct light only; default: the preset's own bound)
 */
#include "cli_queue.h"
#include "pf_cli.h"

#include <string.h>

int pf_cli_sampling_option(const char *command, const char *arg, const char *value,
                           pf_render_settings *settings)
{
    if (!strcmp(arg, "--filter")) {
        int filter = pf_pixel_filter_parse(value);
        if (filter < 0)
            return pf_cli_fail(command, 2,
                               "--filter '%s': expected gaussian, box or blackman-harris", value);
        settings->pixel_filter = (pf_pixel_filter)filter;
        return 0;
    }
    if (!strcmp(arg, "--max-bounces")) {
        int64_t bounces;
        if (!pf_cli_parse_int(value, 0, PF_MAX_BOUNCES_LIMIT, &bounces))
            return pf_cli_fail(command, 2, "--max-bounces '%s': expected an integer 0..%u", value,
                               PF_MAX_BOUNCES_LIMIT);
        settings->bounce_limit = pf_bounce_limit((uint32_t)bounces);
        return 0;
    }
    return -1;
}
