/*
 * The options of render and enqueue that shape the image whatever the preset
 * (cli_queue.h):
 *   --filter NAME        pixel filter: gaussian (default), box, blackman-harris
 *   --max-bounces N      reference, final: light of at most N bounces (0..1024;
 *                        0 = direct light only; default: the preset's own bound)
 *   --budget-ms MS       auto: aim at this wall time per frame (1..86400000)
 *   --target-relmse X    auto: aim at this relMSE (more than 0, at most 100)
 */
#include "cli_queue.h"
#include "pf_cli.h"

#include <stdlib.h>
#include <string.h>

#define MAX_BUDGET_MS 86400000.0
#define MAX_TARGET_RELMSE 100.0

/* A finite number in (0, max], the whole string. */
static int parse_positive(const char *value, double max, double *out)
{
    char *end = NULL;
    double number = value ? strtod(value, &end) : 0.0;
    if (!value || end == value || *end || !(number > 0.0) || !(number <= max))
        return 0;
    *out = number;
    return 1;
}

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
    if (!strcmp(arg, "--budget-ms")) {
        if (!parse_positive(value, MAX_BUDGET_MS, &settings->budget_ms))
            return pf_cli_fail(command, 2,
                               "--budget-ms '%s': expected milliseconds per frame, more than 0 "
                               "and at most %.0f",
                               value, MAX_BUDGET_MS);
        return 0;
    }
    if (!strcmp(arg, "--target-relmse")) {
        if (!parse_positive(value, MAX_TARGET_RELMSE, &settings->target_relmse))
            return pf_cli_fail(command, 2,
                               "--target-relmse '%s': expected a relMSE more than 0 and at most "
                               "%.0f",
                               value, MAX_TARGET_RELMSE);
        return 0;
    }
    return -1;
}
