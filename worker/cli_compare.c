/*
 * photonfarm compare A.exr B.exr [--format text|json]: the error of test image A
 * against reference B (DESIGN.md §8): RMSE, relMSE (ε = PF_RELMSE_EPSILON),
 * max abs error, and per-channel means of both. Exit 0 ok, 2 bad usage or an
 * unreadable/mismatched image, 1 anything else.
 */
#include "cli_options.h"
#include "pf_cli.h"
#include "pf_image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* JSON has no NaN or infinity: those become null. */
static void print_json_number(double value)
{
    if (isfinite(value))
        printf("%.9g", value);
    else
        printf("null");
}

static void print_json_string(const char *text)
{
    putchar('"');
    for (const unsigned char *p = (const unsigned char *)text; *p; p++) {
        if (*p == '"' || *p == '\\')
            printf("\\%c", *p);
        else if (*p < 0x20)
            printf("\\u%04x", *p);
        else
            putchar(*p);
    }
    putchar('"');
}

static void print_json(const char *path_a, const char *path_b, const pf_image *a,
                       const pf_image_metrics *metrics)
{
    printf("{\"a\": ");
    print_json_string(path_a);
    printf(", \"b\": ");
    print_json_string(path_b);
    printf(", \"width\": %u, \"height\": %u, \"rmse\": ", a->width, a->height);
    print_json_number(metrics->rmse);
    printf(", \"relmse\": ");
    print_json_number(metrics->relmse);
    printf(", \"max_abs_error\": ");
    print_json_number(metrics->max_abs_error);
    printf(", \"relmse_epsilon\": %g, \"channels\": [", PF_RELMSE_EPSILON);
    for (uint32_t c = 0; c < metrics->channel_count; c++) {
        printf("%s{\"name\": ", c ? ", " : "");
        print_json_string(a->channel_names[c]);
        printf(", \"mean_a\": ");
        print_json_number(metrics->mean_a[c]);
        printf(", \"mean_b\": ");
        print_json_number(metrics->mean_b[c]);
        printf("}");
    }
    printf("]}\n");
}

static void print_text(const char *path_a, const char *path_b, const pf_image *a,
                       const pf_image_metrics *metrics)
{
    printf("A: %s\nB: %s (reference)\nsize: %ux%u, %u channels\n", path_a, path_b, a->width,
           a->height, a->channel_count);
    printf("RMSE:          %.9g\n", metrics->rmse);
    printf("relMSE:        %.9g (epsilon %g)\n", metrics->relmse, PF_RELMSE_EPSILON);
    printf("max abs error: %.9g\n", metrics->max_abs_error);
    printf("%-24s %16s %16s\n", "channel", "mean A", "mean B");
    for (uint32_t c = 0; c < metrics->channel_count; c++)
        printf("%-24s %16.9g %16.9g\n", a->channel_names[c], metrics->mean_a[c],
               metrics->mean_b[c]);
}

/*
 * Two images sampled through different pixel filters differ at every edge
 * whatever made them (issue 16: 0.048 relMSE on one row of the Cornell box),
 * so the figures would measure the filters: said on stderr, the comparison
 * still runs. A file without the attribute (another renderer's) is named.
 */
static void warn_filters(const char *const paths[2], pf_image_attribute *const attributes[2],
                         const uint32_t count[2])
{
    const char *filter[2];
    for (int k = 0; k < 2; k++)
        filter[k] = pf_image_attribute_value(attributes[k], count[k], "photonfarm/pixelFilter");
    if (filter[0] && filter[1] && strcmp(filter[0], filter[1]) != 0)
        fprintf(stderr,
                "photonfarm compare: warning: different pixel filters (%s: %s, %s: %s); edges "
                "differ whatever rendered them\n",
                paths[0], filter[0], paths[1], filter[1]);
    else if (!filter[0] != !filter[1])
        fprintf(stderr,
                "photonfarm compare: warning: %s records no pixel filter (%s used %s); edges "
                "differ if its filter is not the same\n",
                paths[filter[0] ? 1 : 0], paths[filter[0] ? 0 : 1], filter[0] ? filter[0] : filter[1]);
}

int pf_cli_compare(int argc, char **argv)
{
    const char *paths[2] = {NULL, NULL}, *format = "text";
    int rgb_only = 0;
    const pf_cli_option options[] = {
        {"--format", NULL, "F", "text or json", "text", pf_cli_store_choice, &format, 0, 0,
         "text|json"},
        {"--rgb", NULL, NULL,
         "compare R, G, B alone (a preview against a reference's\nlayers)",
         "every channel, matched by name", pf_cli_store_flag, &rgb_only, 0, 0, NULL},
    };
    char description[1024];
    snprintf(description, sizeof description,
             "Error of test image A against reference B, over the R, G, B channels\n"
             "(every channel when the images have no R, G and B):\n"
             "  RMSE     sqrt(mean (a - b)^2)\n"
             "  relMSE   mean (a - b)^2 / (b^2 + %g)\n"
             "  max      max |a - b|\n"
             "and the mean of every channel in both images. The images must have the\n"
             "same size and the same channel names (exit 2 otherwise).",
             PF_RELMSE_EPSILON);
    pf_cli_command command = {
        .name = "compare",
        .synopsis = "A.exr B.exr [options]",
        .description = description,
        .options = options,
        .option_count = sizeof options / sizeof options[0],
        .positional = paths,
        .positional_max = 2,
    };
    int help = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    if (command.positional_count != 2)
        return pf_cli_fail("compare", 2, "need two EXR files, got %zu (see --help)",
                           command.positional_count);
    int json = !strcmp(format, "json");

    pf_error err = {0};
    pf_image a = {0}, b = {0};
    pf_image_metrics metrics;
    pf_image_attribute *attributes[2] = {NULL, NULL};
    uint32_t attribute_count[2] = {0, 0};
    pf_status status = pf_exr_read(paths[0], &a, &attributes[0], &attribute_count[0], &err);
    if (status == PF_OK)
        status = pf_exr_read(paths[1], &b, &attributes[1], &attribute_count[1], &err);
    if (status == PF_OK)
        warn_filters(paths, attributes, attribute_count);
    free(attributes[0]);
    free(attributes[1]);
    if (status == PF_OK && rgb_only) {
        static const char *const rgb[3] = {"R", "G", "B"};
        pf_image *images[2] = {&a, &b};
        for (int k = 0; k < 2 && status == PF_OK; k++) {
            pf_image selected;
            status = pf_image_select(images[k], rgb, 3, &selected, &err);
            if (status != PF_OK) {
                pf_error_prefix(&err, "%s", paths[k]);
                break;
            }
            pf_image_free(images[k]);
            *images[k] = selected;
        }
    }
    if (status == PF_OK) {
        status = pf_image_compare(&a, &b, &metrics, &err);
        if (status != PF_OK)
            pf_error_prefix(&err, "%s vs %s", paths[0], paths[1]);
    }
    if (status == PF_OK) {
        if (json)
            print_json(paths[0], paths[1], &a, &metrics);
        else
            print_text(paths[0], paths[1], &a, &metrics);
    }
    pf_image_free(&a);
    pf_image_free(&b);
    if (status != PF_OK)
        return pf_cli_fail("compare", pf_status_exit_code(status), "%s", err.message);
    return fflush(stdout) == 0 ? 0 : pf_cli_fail("compare", 1, "cannot write the report");
}
