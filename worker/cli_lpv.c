/*
 * The `fast` preset's LPV options, shared by render and enqueue (cli_queue.h):
 *   --lpv-cascades N        cascades (1..8, default 4)
 *   --lpv-size N            cells per axis of each cascade (a multiple of 4, 4..256, default 32)
 *   --lpv-iterations N[,N]  propagation iterations, one value or one per cascade
 *                           (1..1024, default 8)
 *   --lpv-cell METERS       the finest cascade's cell (default: from the scene)
 */
#include "cli_queue.h"
#include "pf_cli.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *option_of(pf_lpv_setting which)
{
    switch (which) {
    case PF_LPV_SETTING_CASCADES:
        return "--lpv-cascades";
    case PF_LPV_SETTING_SIZE:
        return "--lpv-size";
    case PF_LPV_SETTING_ITERATIONS:
        return "--lpv-iterations";
    case PF_LPV_SETTING_CELL_SIZE:
        return "--lpv-cell";
    default:
        return "--lpv-*";
    }
}

int pf_cli_lpv_option(const char *command, const char *arg, const char *value,
                      pf_lpv_settings *lpv)
{
    int64_t number;
    if (!strcmp(arg, "--lpv-cascades")) {
        if (!pf_cli_parse_int(value, 1, PF_LPV_MAX_CASCADES, &number))
            return pf_cli_fail(command, 2, "--lpv-cascades '%s': expected an integer 1..%u",
                               value, PF_LPV_MAX_CASCADES);
        lpv->cascades = (uint32_t)number;
    } else if (!strcmp(arg, "--lpv-size")) {
        if (!pf_cli_parse_int(value, PF_LPV_MIN_SIZE, PF_LPV_MAX_SIZE, &number) || number % 4)
            return pf_cli_fail(command, 2,
                               "--lpv-size '%s': expected a multiple of 4 in %u..%u (cells per "
                               "axis)",
                               value, PF_LPV_MIN_SIZE, PF_LPV_MAX_SIZE);
        lpv->size = (uint32_t)number;
    } else if (!strcmp(arg, "--lpv-iterations")) {
        char buffer[256];
        if (strlen(value) >= sizeof buffer)
            return pf_cli_fail(command, 2, "--lpv-iterations: value too long");
        snprintf(buffer, sizeof buffer, "%s", value);
        uint32_t count = 0;
        char *save = NULL;
        memset(lpv->iterations, 0, sizeof lpv->iterations);
        for (char *item = strtok_r(buffer, ",", &save); item; item = strtok_r(NULL, ",", &save)) {
            if (count >= PF_LPV_MAX_CASCADES ||
                !pf_cli_parse_int(item, 1, PF_LPV_MAX_ITERATIONS, &number))
                return pf_cli_fail(command, 2,
                                   "--lpv-iterations '%s': expected 1..%u, or up to %u of them "
                                   "separated by commas (one per cascade)",
                                   value, PF_LPV_MAX_ITERATIONS, PF_LPV_MAX_CASCADES);
            lpv->iterations[count++] = (uint32_t)number;
        }
        if (count == 0 || value[0] == ',' || value[strlen(value) - 1] == ',' ||
            strstr(value, ",,"))
            return pf_cli_fail(command, 2, "--lpv-iterations '%s': expected 1..%u", value,
                               PF_LPV_MAX_ITERATIONS);
    } else if (!strcmp(arg, "--lpv-cell")) {
        char *end = NULL;
        errno = 0;
        double cell = strtod(value, &end);
        if (errno || !*value || *end || !isfinite(cell) || !(cell > 0.0) || cell > 1e6)
            return pf_cli_fail(command, 2, "--lpv-cell '%s': expected a size in meters, more "
                                           "than 0 and at most 1e6",
                               value);
        lpv->cell_size = (float)cell;
    } else {
        return -1;
    }
    return 0;
}

int pf_cli_lpv_check(const char *command, const pf_lpv_settings *lpv, uint64_t max_buffer_bytes)
{
    pf_lpv_setting which;
    pf_error err = {0};
    if (pf_lpv_settings_check(lpv, max_buffer_bytes, &which, &err) != PF_OK)
        return pf_cli_fail(command, 2, "%s: %s", option_of(which), err.message);
    return 0;
}
