/*
 * One render-settings type, one option parser, one codec: every field of
 * pf_render_settings survives command line → struct → job JSON → struct, the
 * same options mean the same thing to `render` and `enqueue`, and what lands
 * in the queue and in an EXR's photonfarm/settings decodes to what was asked.
 */
#include "cli_queue.h"
#include "job_extras.h"
#include "pf_image.h"
#include "pf_test.h"
#include "worker_test_util.h"

#include <stdarg.h>
#include <string.h>

/* A new field must be added to settings_equal, every_field and the codec: this fails first. */
_Static_assert(sizeof(pf_render_settings) == 160,
               "pf_render_settings changed: cover the new field in this test and core/render/settings.c");

static char last_failure[1024];

/* The CLI's error printer (worker/main.c), captured instead of printed. */
int pf_cli_fail(const char *command, int exit_code, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    int length = snprintf(last_failure, sizeof last_failure, "%s: ", command);
    vsnprintf(last_failure + length, sizeof last_failure - (size_t)length, format, args);
    va_end(args);
    return exit_code;
}

/* Field by field (no memcmp: padding), naming the first difference. */
static int settings_equal_report(const pf_render_settings *a, const pf_render_settings *b,
                                 int report)
{
#define SAME(field)                                                                       \
    if (a->field != b->field) {                                                           \
        if (report)                                                                       \
            fprintf(stderr, "  %s differs\n", #field);                                    \
        return 0;                                                                         \
    }
    SAME(width) SAME(height) SAME(quality) SAME(samples_per_pixel) SAME(seed) SAME(aovs)
    SAME(time_budget_ms) SAME(photons_per_pass) SAME(pixel_filter) SAME(bounce_limit)
    SAME(budget_ms) SAME(target_relmse) SAME(float_pixels) SAME(denoise) SAME(lpv.cascades)
    SAME(lpv.size)
    SAME(lpv.cell_size) SAME(lpv.offset_cells) SAME(lpv.undamped) SAME(lpv.unscaled)
    /* sample_salt, sample_scale and the band are the frame pipeline's, not a job's: the codec
     * leaves them out (below). */
    for (uint32_t k = 0; k < PF_LPV_MAX_CASCADES; k++)
        SAME(lpv.iterations[k])
#undef SAME
    return 1;
}

static int settings_equal(const pf_render_settings *a, const pf_render_settings *b)
{
    return settings_equal_report(a, b, 1);
}

/* Every command-line settings option at a value other than its default. */
static const char *const every_option[] = {
    "--size", "320x200", "--quality", "final", "--spp", "7", "--seed", "9007199254740992",
    "--photons", "54321", "--time-budget", "12.5", "--float", "--no-aovs", "--filter",
    "blackman-harris", "--max-bounces", "3", "--budget-ms", "2500", "--target-relmse", "0.02",
    "--lpv-cascades", "3", "--lpv-size", "24", "--lpv-iterations", "5,6,7", "--lpv-cell",
    "0.125", "--denoise", "off"};
#define OPTION_COUNT (sizeof every_option / sizeof every_option[0])

/* What every_option means, written out by hand. */
static pf_render_settings every_field(void)
{
    pf_render_settings s = pf_render_settings_default();
    s.width = 320;
    s.height = 200;
    s.quality = PF_QUALITY_FINAL;
    s.samples_per_pixel = 7;
    s.seed = 9007199254740992ull;
    s.photons_per_pass = 54321;
    s.time_budget_ms = 12500.0;
    s.float_pixels = 1;
    s.aovs = 0;
    s.pixel_filter = PF_FILTER_BLACKMAN_HARRIS;
    s.bounce_limit = pf_bounce_limit(3);
    s.budget_ms = 2500.0;
    s.target_relmse = 0.02;
    s.lpv.cascades = 3;
    s.lpv.size = 24;
    s.lpv.iterations[0] = 5;
    s.lpv.iterations[1] = 6;
    s.lpv.iterations[2] = 7;
    s.lpv.cell_size = 0.125f;
    s.denoise = PF_DENOISE_OFF;
    return s;
}

/* Runs the one option parser over argv as render and enqueue do; 0 or its exit code. */
static int parse_argv(const char *const *argv, size_t count, pf_render_settings *settings)
{
    *settings = pf_render_settings_default();
    pf_cli_scene scene = {0};
    pf_cli_option rows[PF_CLI_SETTINGS_OPTIONS];
    pf_cli_settings_table(settings, &scene, rows);
    pf_cli_command command = {
        .name = "test",
        .synopsis = "",
        .description = "",
        .options = rows,
        .option_count = PF_CLI_SETTINGS_OPTIONS,
    };
    char *args[64] = {"test"};
    for (size_t i = 0; i < count && i + 1 < 64; i++)
        args[i + 1] = (char *)argv[i];
    int help = 0;
    return pf_cli_parse(&command, (int)count + 1, args, &help);
}

static void expect_json_round_trip(const pf_render_settings *settings, const char *what)
{
    char json[2048];
    pf_job_extras extras = {"name", 1};
    PF_REQUIRE(pf_job_parameters_format(settings, &extras, json, sizeof json));
    pf_render_settings decoded;
    pf_error err = {0};
    PF_CHECK_OK(pf_settings_parse(json, &decoded, &err), &err);
    PF_CHECK_MSG(settings_equal(settings, &decoded), "%s: %s", what, json);
    char name[16];
    pf_job_name(json, name, sizeof name);
    PF_CHECK(!strcmp(name, "name") && pf_job_allow_outside(json) == 1);
    /* The settings alone carry none of the farm's keys. */
    PF_REQUIRE(pf_settings_format(settings, json, sizeof json));
    pf_job_name(json, name, sizeof name);
    PF_CHECK(!strcmp(name, "") && pf_job_allow_outside(json) == 0);
}

PF_TEST(the_command_line_sets_every_field)
{
    pf_render_settings parsed;
    PF_REQUIRE(parse_argv(every_option, OPTION_COUNT, &parsed) == 0);
    pf_render_settings expected = every_field();
    PF_CHECK(settings_equal(&parsed, &expected));
}

PF_TEST(every_field_survives_the_job_json_alone_and_together)
{
    pf_render_settings defaults = pf_render_settings_default();
    expect_json_round_trip(&defaults, "defaults");
    pf_render_settings all = every_field();
    all.lpv.offset_cells = 0.75f; /* the measurement-only fields (no option) too */
    all.lpv.undamped = 1;
    all.lpv.unscaled = 1;
    expect_json_round_trip(&all, "every field");
    /* One option at a time on top of the defaults: no field depends on another to survive. */
    for (size_t i = 0; i < OPTION_COUNT; i++) {
        if (strncmp(every_option[i], "--", 2) != 0)
            continue;
        int flag = i + 1 >= OPTION_COUNT || !strncmp(every_option[i + 1], "--", 2);
        pf_render_settings one;
        PF_REQUIRE(parse_argv(&every_option[i], flag ? 1 : 2, &one) == 0);
        PF_CHECK_MSG(!settings_equal_report(&one, &defaults, 0), "%s changed nothing", every_option[i]);
        expect_json_round_trip(&one, every_option[i]);
    }
}

/* The frame number the pipeline salts the camera samples with, the sample scale of a run's
 * first frame and the band of rows a render is of its frame are no settings of the job: two
 * frames of one job store and stamp the same JSON. */
PF_TEST(the_codec_leaves_the_sample_salt_out)
{
    pf_render_settings plain = every_field(), salted = plain;
    salted.sample_salt = 17;
    salted.sample_scale = PF_TEMPORAL_WARM_UP;
    salted.band_row_first = 720;
    salted.band_image_height = 2160;
    char a[1024], b[1024];
    PF_REQUIRE(pf_settings_format(&plain, a, sizeof a));
    PF_REQUIRE(pf_settings_format(&salted, b, sizeof b));
    PF_CHECK_MSG(!strcmp(a, b), "%s\n  against %s", b, a);
    pf_render_settings parsed;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_settings_parse(b, &parsed, &err), &err);
    PF_CHECK(parsed.sample_salt == 0);
    PF_CHECK(parsed.sample_scale == 0);
    PF_CHECK(parsed.band_row_first == 0 && parsed.band_image_height == 0);
}

PF_TEST(the_parser_and_the_codec_share_their_bounds)
{
    /* Bounds: the last value accepted and the first refused, on the command line and in JSON. */
    static const struct {
        const char *option, *accepted, *refused, *json_refused;
    } bounds[] = {
        {"--spp", "65536", "65537", "{\"spp\":65537}"},
        {"--seed", "9007199254740992", "9007199254740993", "{\"seed\":18014398509481984}"},
        {"--photons", "100000000", "100000001", "{\"photons\":100000001}"},
        {"--time-budget", "604800", "604801", "{\"time_budget_ms\":604801000}"},
        {"--budget-ms", "86400000", "86400001", "{\"budget_ms\":86400001}"},
        {"--target-relmse", "100", "100.5", "{\"target_relmse\":100.5}"},
        {"--max-bounces", "1024", "1025", "{\"max_bounces\":1025}"},
        {"--size", "16384x1", "16385x1", "{\"width\":16385}"},
        {"--size", "1x16384", "4294967297x1", "{\"height\":4294967297}"}, /* no wrap */
        {"--size", "7x5", "7x", "{\"width\":-1}"},
        {"--spp", "1", "1e3", "{\"spp\":1.5}"},
        {"--denoise", "on", "yes", "{\"denoise\":true}"},
    };
    for (size_t i = 0; i < sizeof bounds / sizeof bounds[0]; i++) {
        pf_render_settings settings;
        const char *good[] = {bounds[i].option, bounds[i].accepted};
        const char *bad[] = {bounds[i].option, bounds[i].refused};
        PF_CHECK_MSG(parse_argv(good, 2, &settings) == 0, "%s %s: %s", bounds[i].option,
                     bounds[i].accepted, last_failure);
        last_failure[0] = '\0';
        PF_CHECK_MSG(parse_argv(bad, 2, &settings) == 2, "%s %s accepted", bounds[i].option,
                     bounds[i].refused);
        PF_CHECK_MSG(strstr(last_failure, bounds[i].option) != NULL, "message: %s",
                     last_failure);
        pf_error err = {0};
        PF_CHECK_MSG(pf_settings_parse(bounds[i].json_refused, &settings, &err) ==
                         PF_ERR_FORMAT,
                     "%s accepted", bounds[i].json_refused);
    }
    /* A value-taking option at the end of the line, and options that are not settings. */
    pf_render_settings settings;
    const char *dangling[] = {"--spp"};
    PF_CHECK(parse_argv(dangling, 1, &settings) == 2 && strstr(last_failure, "needs a value"));
    const char *other[] = {"--db", "x.db"};
    PF_CHECK(parse_argv(other, 2, &settings) == 2 && strstr(last_failure, "unknown option"));
}

/*
 * The one option parser every subcommand uses: --name VALUE and --name=VALUE,
 * aliases, flags that refuse a value, strict integers with their range,
 * choices, positional arguments up to their number, and a --help that lists
 * every option with its default.
 */
PF_TEST(the_option_table_parses_and_documents_every_option)
{
    const char *text = NULL, *choice = "a", *positional[2] = {NULL, NULL};
    int flag = 0, help = 0;
    int64_t number = 0;
    const pf_cli_option options[] = {
        {"--text", "-t", "T", "some text", "none", pf_cli_store_text, &text, 0, 0, NULL},
        {"--flag", NULL, NULL, "a flag", "off", pf_cli_store_flag, &flag, 0, 0, NULL},
        {"--number", NULL, "N", "a number", "0", pf_cli_store_int, &number, -5, 5, NULL},
        {"--choice", NULL, "C", "one of a, b", "a", pf_cli_store_choice, &choice, 0, 0, "a|b"},
    };
    pf_cli_command command = {
        .name = "test",
        .synopsis = "[options]",
        .description = "Tests.",
        .options = options,
        .option_count = 4,
        .positional = positional,
        .positional_max = 2,
    };
    char *good[] = {"test", "one", "--text=x=y", "--flag", "--number", "-5", "-t", "z",
                    "--choice=b", "two"};
    PF_CHECK(pf_cli_parse(&command, 10, good, &help) == 0 && !help);
    PF_CHECK(text && !strcmp(text, "z") && flag == 1 && number == -5 && !strcmp(choice, "b"));
    PF_CHECK(command.positional_count == 2 && !strcmp(positional[0], "one") &&
             !strcmp(positional[1], "two"));
    char *equals[] = {"test", "--text=x=y"};
    PF_CHECK(pf_cli_parse(&command, 2, equals, &help) == 0 && !strcmp(text, "x=y"));
    static const struct {
        char *arg, *value;
        const char *message;
    } bad[] = {
        {"--number", "6", "expected an integer -5..5"},
        {"--number", "1x", "expected an integer -5..5"},
        {"--number", "4294967297", "expected an integer -5..5"},
        {"--choice", "c", "expected one of a|b"},
        {"--flag=1", NULL, "takes no value"},
        {"--nope", NULL, "unknown option '--nope'"},
        {"--text", NULL, "needs a value"},
        {"three", NULL, "unexpected argument 'three'"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char *argv[] = {"test", "a", "b", bad[i].arg, bad[i].value};
        int argc = bad[i].value ? 5 : 4;
        last_failure[0] = '\0';
        int code = pf_cli_parse(&command, argc, argv, &help);
        PF_CHECK_MSG(code == 2 && strstr(last_failure, bad[i].message), "%s %s: %d, \"%s\"",
                     bad[i].arg, bad[i].value ? bad[i].value : "", code, last_failure);
    }
    /* --help: every option with its default, from the same table. */
    char path[WT_PATH_MAX];
    pf_test_tmpdir(path, sizeof path);
    strncat(path, "/help.txt", sizeof path - strlen(path) - 1);
    FILE *out = fopen(path, "w");
    PF_REQUIRE(out != NULL);
    pf_cli_print_help(&command, out);
    fclose(out);
    const char *expected[] = {"usage: photonfarm test [options]", "-t, --text T",
                              "some text (default: none)", "--flag", "a flag (default: off)",
                              "--number N", "--choice C", "one of a, b (default: a)",
                              "-h, --help", "Exit status: 0 ok"};
    for (size_t i = 0; i < sizeof expected / sizeof expected[0]; i++)
        PF_CHECK(wt_file_contains(path, expected[i]));
}

/* The settings string of an EXR (photonfarm/settings), or "" when absent. */
static void exr_settings(const char *path, char *out, size_t size)
{
    pf_image image = {0};
    pf_image_attribute *attributes = NULL;
    uint32_t count = 0;
    pf_error err = {0};
    out[0] = '\0';
    PF_CHECK_OK(pf_exr_read(path, &image, &attributes, &count, &err), &err);
    const char *settings = pf_image_attribute_value(attributes, count, "photonfarm/settings");
    if (settings)
        snprintf(out, size, "%s", settings);
    free(attributes);
    pf_image_free(&image);
}

/* enqueue and render given the same options store and write the same settings. */
PF_TEST(enqueue_and_render_record_what_the_options_say)
{
    char dir[WT_PATH_MAX], scene[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32];
    wt_fresh_dir("codec", dir, sizeof dir);
    wt_format(scene, sizeof scene, "%s/tiny.gltf", dir);
    wt_format(db, sizeof db, "%s/farm.db", dir);
    wt_write_tiny_scene(scene, 2);
    /* Cheap to render (preview, 12×8) yet every other field non-default. */
    char options[2048] = "";
    const char *argv[OPTION_COUNT];
    for (size_t i = 0; i < OPTION_COUNT; i++) {
        argv[i] = every_option[i];
        if (!strcmp(every_option[i], "final"))
            argv[i] = "preview";
        else if (!strcmp(every_option[i], "320x200"))
            argv[i] = "12x8";
        size_t length = strlen(options);
        snprintf(options + length, sizeof options - length, " %s", argv[i]);
    }
    pf_render_settings asked;
    PF_REQUIRE(parse_argv(argv, OPTION_COUNT, &asked) == 0);

    char args[4 * WT_PATH_MAX];
    wt_format(args, sizeof args, "enqueue '%s' --frames 1-2 --out '%s/q.####.exr' --db '%s'%s",
              scene, dir, db, options);
    PF_REQUIRE(wt_run(args, NULL) == 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, 1, &job, &err), &err);
    pf_render_settings stored;
    PF_CHECK_OK(pf_settings_parse(job.parameters_json, &stored, &err), &err);
    PF_CHECK_MSG(settings_equal(&asked, &stored), "queued: %s", job.parameters_json);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);

    wt_format(args, sizeof args, "render '%s' --frame 2 -o '%s/r.####.exr'%s", scene, dir,
              options);
    PF_REQUIRE(wt_run(args, NULL) == 0);
    char path[WT_PATH_MAX + 32], json[2048];
    wt_format(path, sizeof path, "%s/r.0002.exr", dir);
    exr_settings(path, json, sizeof json);
    pf_render_settings written;
    PF_CHECK_OK(pf_settings_parse(json, &written, &err), &err);
    PF_CHECK_MSG(settings_equal(&asked, &written), "in the EXR: %s", json);
}

int main(void)
{
    PF_RUN(the_command_line_sets_every_field);
    PF_RUN(the_option_table_parses_and_documents_every_option);
    PF_RUN(every_field_survives_the_job_json_alone_and_together);
    PF_RUN(the_parser_and_the_codec_share_their_bounds);
    PF_RUN(the_codec_leaves_the_sample_salt_out);
    PF_RUN(enqueue_and_render_record_what_the_options_say);
    return pf_test_finish();
}
