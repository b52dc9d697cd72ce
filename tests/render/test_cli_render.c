/* `photonfarm render`: frame sequences to EXR, and every bad-input exit path. */
#include "pf_image.h"
#include "pf_test.h"

#include <dirent.h>
#include <sys/wait.h>

static char tmpdir[1024];
static char log_path[1100];

/* Runs photonfarm with arguments (shell-quoted by the caller); returns its exit code. */
static int run_photonfarm(const char *arguments)
{
    const char *binary = getenv("PHOTONFARM");
    char command[8192];
    int length = snprintf(command, sizeof command, "'%s' %s >'%s' 2>&1",
                          binary ? binary : "photonfarm", arguments, log_path);
    if (length < 0 || (size_t)length >= sizeof command)
        return -1; /* a truncated command would run something else */
    int status = system(command);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* The last run's output (at most size - 1 bytes of it) in buffer; "" when unreadable. */
static void log_read(char *buffer, size_t size)
{
    buffer[0] = '\0';
    FILE *file = fopen(log_path, "rb");
    if (!file)
        return;
    size_t length = fread(buffer, 1, size - 1, file);
    fclose(file);
    buffer[length] = '\0';
}

/* Whether the last run's output contains text, printing the output when it does not
 * and loud is set. */
static int log_search(const char *text, int loud)
{
    char buffer[8192];
    log_read(buffer, sizeof buffer);
    if (strstr(buffer, text))
        return 1;
    if (loud)
        fprintf(stderr, "expected '%s' in the output:\n%s\n", text, buffer);
    return 0;
}

static int log_contains(const char *text) { return log_search(text, 1); }
static int log_contains_quietly(const char *text) { return log_search(text, 0); }

/* How many times text occurs in the last run's output. */
static int log_count(const char *text)
{
    char buffer[16384];
    log_read(buffer, sizeof buffer);
    int count = 0;
    for (const char *at = strstr(buffer, text); at; at = strstr(at + 1, text))
        count++;
    return count;
}

static int file_exists(const char *path)
{
    FILE *file = fopen(path, "rb");
    if (file)
        fclose(file);
    return file != NULL;
}

PF_TEST(renders_a_frame_range_to_numbered_exr_files)
{
    char scene[1024], args[4096], path[2048];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    snprintf(args, sizeof args,
             "render '%s' --frames 1-2 --size 16x12 --quality preview -o '%s/f.####.exr' "
             "--cache-dir '%s/shader-cache/nested'",
             scene, tmpdir, tmpdir);
    PF_REQUIRE(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("f.0002.exr"));
    /* The compiled-shader cache: its directory made (parents too), the pipeline file written. */
    snprintf(path, sizeof path, "%s/shader-cache/nested", tmpdir);
    DIR *cache = opendir(path);
    PF_CHECK_MSG(cache != NULL, "%s not created", path);
    int cache_files = 0;
    struct dirent *cached;
    while (cache && (cached = readdir(cache)) != NULL)
        cache_files += strstr(cached->d_name, ".vkcache") != NULL;
    if (cache)
        closedir(cache);
    PF_CHECK_MSG(cache_files == 1, "%d pipeline cache files in %s", cache_files, path);
    for (int frame = 1; frame <= 2; frame++) {
        snprintf(path, sizeof path, "%s/f.%04d.exr", tmpdir, frame);
        PF_CHECK_MSG(file_exists(path), "%s missing", path);
        pf_image image = {0};
        pf_image_attribute *attributes = NULL;
        uint32_t attribute_count = 0;
        pf_error err = {0};
        PF_CHECK_OK(pf_exr_read(path, &image, &attributes, &attribute_count, &err), &err);
        PF_CHECK(image.width == 16 && image.height == 12 && image.channel_count == 13);
        PF_CHECK(pf_image_channel(&image, "motion.X") == 11 &&
                 pf_image_channel(&image, "motion.Y") == 12);
        const char *stored_frame =
            pf_image_attribute_value(attributes, attribute_count, "photonfarm/frame");
        const char *settings =
            pf_image_attribute_value(attributes, attribute_count, "photonfarm/settings");
        const char *device = pf_image_attribute_value(attributes, attribute_count, "photonfarm/device");
        int found_frame = stored_frame && atoi(stored_frame) == frame;
        int found_settings = settings && strstr(settings, "\"width\":16") != NULL &&
                             strstr(settings, "\"height\":12") != NULL;
        int found_device = device && device[0] != '\0';
        PF_CHECK_MSG(found_frame, "%s: photonfarm/frame attribute missing or wrong", path);
        PF_CHECK_MSG(found_settings, "%s: photonfarm/settings attribute missing or wrong", path);
        PF_CHECK_MSG(found_device, "%s: photonfarm/device attribute missing", path);
        free(attributes);
        pf_image_free(&image);
    }
    DIR *dir = opendir(tmpdir);
    PF_REQUIRE(dir != NULL);
    struct dirent *entry;
    while ((entry = readdir(dir)) != NULL)
        PF_CHECK_MSG(!strstr(entry->d_name, ".tmp"), "temporary file left: %s", entry->d_name);
    closedir(dir);
}

/*
 * Temporal reuse through `render --frames` (issue 40): frame 1 has no history and starts
 * the run with 4× the samples (its neighbour on another worker would have a long history),
 * frames 2 and 3 blend the frame before with the samples asked (their motion vectors traced
 * for it even without AOVs, which the file then leaves out), a moving light stops the reuse,
 * --denoise spatial keeps every frame alone (no warm-up), a frame alone gets none either,
 * and a bad mode is exit 2.
 */
PF_TEST(consecutive_frames_reuse_the_one_before)
{
    char scene[1024], args[4096], path[2048];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    snprintf(args, sizeof args,
             "render '%s' --frames 1-3 --size 16x12 --quality reference --spp 2 --no-aovs "
             "--timings -o '%s/t.####.exr'",
             scene, tmpdir);
    PF_REQUIRE(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("temporal       skipped: no previous frame of this sequence"));
    PF_CHECK(log_contains("previous frame (1) on this worker;"));
    PF_CHECK(log_contains("previous frame (2) on this worker;"));
    PF_CHECK(log_contains("path samples: 2 per pixel (asked) × 4 (first of a run, nothing to "
                          "blend)"));
    PF_CHECK(log_contains("samples_per_pixel=8 "));
    PF_CHECK(log_contains("samples_per_pixel=2 "));
    snprintf(path, sizeof path, "%s/t.0003.exr", tmpdir);
    pf_image image = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_exr_read(path, &image, NULL, NULL, &err), &err);
    PF_CHECK_MSG(image.channel_count == 4, "%u channels without AOVs", image.channel_count);
    pf_image_free(&image);
    snprintf(args, sizeof args,
             "render '%s' --frames 1-2 --size 16x12 --quality reference --spp 2 --timings "
             "--denoise spatial -o '%s/s.####.exr'",
             scene, tmpdir);
    PF_REQUIRE(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("skipped: --denoise spatial: every frame filtered alone"));
    PF_CHECK(!log_contains_quietly("on this worker;"));
    PF_CHECK(!log_contains_quietly("first of a run"));
    snprintf(args, sizeof args,
             "render '%s' --frame 2 --size 16x12 --quality reference --spp 2 --timings "
             "-o '%s/one.exr'",
             scene, tmpdir);
    PF_REQUIRE(run_photonfarm(args) == 0);
    PF_CHECK(!log_contains_quietly("first of a run"));
    /* caustic-anim's light moves: the light on every surface changed, nothing is reused. */
    char moving_light[1024];
    pf_test_shared_scene("caustic-anim", moving_light, sizeof moving_light);
    snprintf(args, sizeof args,
             "render '%s' --frames 1-2 --size 16x12 --quality reference --spp 1 --timings "
             "-o '%s/l.####.exr'",
             moving_light, tmpdir);
    PF_REQUIRE(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("temporal       skipped: lights or materials changed since frame 1"));
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 16x12 --denoise sometimes -o '%s/b.exr'", scene,
             tmpdir);
    PF_CHECK(run_photonfarm(args) == 2);
    PF_CHECK(log_contains("expected auto, on, spatial or off"));
}

/*
 * The layers the motion and denoise stages add (motion.X/Y, noisy.R/G/B and variance.Y) are
 * in the image the split integrators create, so the stages write them in place instead of
 * copying the whole image into a wider one: the rows say image_copied=0, and the file has
 * the layers in the order appending gave them. preview's image is not created with them:
 * its motion stage appends (image_copied=1). The split integrators' motion vectors are
 * computed while the device renders the frame's last submission (overlapped=1, and shade's
 * row says overlap_ms); preview's after it (overlapped=0): the same vectors either way.
 */
PF_TEST(later_layers_are_written_in_place)
{
    char scene[1024], args[4096], path[2048];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    static const char *const presets[2] = {"reference", "preview"};
    pf_image vectors[2] = {{0}, {0}}; /* each file, for its motion layer */
    for (int p = 0; p < 2; p++) {
        snprintf(args, sizeof args,
                 "render '%s' --frame 2 --size 16x12 --quality %s --spp 1 --denoise spatial "
                 "--timings -o '%s/layers-%s.exr'",
                 scene, presets[p], tmpdir, presets[p]);
        PF_REQUIRE(run_photonfarm(args) == 0);
        int moved = log_count("traced=1 image_copied=");
        int in_place = log_count("image_copied=0"), copied = log_count("image_copied=1");
        int overlapped = log_count("overlapped=1"), after = log_count("overlapped=0");
        PF_CHECK_MSG(overlapped == (p == 0) && after == (p == 1) &&
                         log_count("overlap_ms=") == (p == 0),
                     "%s: motion overlapped %d times, after the render %d", presets[p],
                     overlapped, after);
        PF_CHECK_MSG(moved == 1, "%s: the motion row traced %d times", presets[p], moved);
        if (p == 0)
            PF_CHECK_MSG(in_place == 2 && copied == 0,
                         "reference: motion and denoise in place %d times, copied %d",
                         in_place, copied);
        else
            PF_CHECK_MSG(in_place == 0 && copied == 1,
                         "preview: motion in place %d times, copied %d", in_place, copied);
        snprintf(path, sizeof path, "%s/layers-%s.exr", tmpdir, presets[p]);
        pf_image image = {0};
        pf_error err = {0};
        PF_CHECK_OK(pf_exr_read(path, &image, NULL, NULL, &err), &err);
        /* The file's channels come sorted by name; the layers' are the last of each. */
        uint32_t expected = p == 0 ? 26u : 13u;
        PF_CHECK_MSG(image.channel_count == expected, "%s: %u channels, expected %u",
                     presets[p], image.channel_count, expected);
        PF_CHECK(pf_image_channel(&image, "motion.X") >= 0 &&
                 pf_image_channel(&image, "motion.Y") >= 0);
        if (p == 0) {
            PF_CHECK(pf_image_channel(&image, "noisy.R") >= 0 &&
                     pf_image_channel(&image, "variance.Y") >= 0);
            /* Filled, not the zero they were created with. */
            int motion = pf_image_channel(&image, "motion.X");
            int noisy = pf_image_channel(&image, "noisy.G");
            int moving = 0, lit = 0;
            for (uint32_t i = 0; motion >= 0 && noisy >= 0 && i < 16u * 12u; i++) {
                moving += image.pixels[(size_t)i * image.channel_count + (uint32_t)motion] != 0.0f;
                lit += image.pixels[(size_t)i * image.channel_count + (uint32_t)noisy] > 0.0f;
            }
            PF_CHECK_MSG(moving > 0 && lit > 0, "%d pixels moving, %d lit", moving, lit);
        }
        vectors[p] = image; /* kept for the comparison below */
    }
    /* The vectors computed during the device's work are those computed after it. */
    size_t differing = 0;
    for (int c = 0; c < 2; c++) {
        const char *name = c ? "motion.Y" : "motion.X";
        int a = pf_image_channel(&vectors[0], name), b = pf_image_channel(&vectors[1], name);
        PF_REQUIRE(a >= 0 && b >= 0);
        for (size_t i = 0; i < 16u * 12u; i++)
            differing += memcmp(&vectors[0].pixels[i * vectors[0].channel_count + (size_t)a],
                                &vectors[1].pixels[i * vectors[1].channel_count + (size_t)b],
                                sizeof(float)) != 0;
    }
    PF_CHECK_MSG(differing == 0, "%zu motion values differ between reference and preview",
                 differing);
    pf_image_free(&vectors[0]);
    pf_image_free(&vectors[1]);
}

/* An unusable cache directory costs compile time, never the frame. */
PF_TEST(unusable_cache_directory_warns_and_renders)
{
    char scene[1024], args[8192], path[1200];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    snprintf(path, sizeof path, "%s/cache-is-a-file", tmpdir);
    FILE *file = fopen(path, "wb");
    PF_REQUIRE(file);
    fclose(file);
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x6 --quality preview -o '%s/u.####.exr' "
             "--cache-dir '%s/sub'",
             scene, tmpdir, path);
    PF_CHECK(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("cannot be created"));
    snprintf(path, sizeof path, "%s/u.0001.exr", tmpdir);
    PF_CHECK_MSG(file_exists(path), "%s missing", path);
}

/* The CLI maps $PHOTONFARM_DEVICE to the device choice (core itself reads no
 * environment); an explicit --device wins over it. */
PF_TEST(the_environment_picks_the_device_through_the_cli)
{
    char scene[1024], args[8192];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    setenv("PHOTONFARM_DEVICE", "no-such-device-anywhere", 1);
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x6 --quality preview -o '%s/e.####.exr'", scene,
             tmpdir);
    PF_CHECK(run_photonfarm(args) == 2);
    PF_CHECK(log_contains("no-such-device-anywhere"));
    PF_CHECK(run_photonfarm("devices") == 2);
    PF_CHECK(log_contains("no-such-device-anywhere"));
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x6 --quality preview -o '%s/e.####.exr' "
             "--device 0",
             scene, tmpdir);
    PF_CHECK(run_photonfarm(args) == 0);
    unsetenv("PHOTONFARM_DEVICE");
}

PF_TEST(bad_frames_scenes_and_options_exit_2)
{
    char scene[1024], args[4096];
    pf_test_shared_scene("cornell-anim", scene, sizeof scene);
    const char *bad_frames[] = {"--frame 0", "--frame 999", "--frames 40-49"};
    for (size_t i = 0; i < sizeof bad_frames / sizeof bad_frames[0]; i++) {
        snprintf(args, sizeof args, "render '%s' %s --size 8x8 -o '%s/bad.####.exr'", scene,
                 bad_frames[i], tmpdir);
        PF_CHECK_MSG(run_photonfarm(args) == 2, "%s", bad_frames[i]);
        PF_CHECK(log_contains("1-48"));
    }
    snprintf(args, sizeof args, "render '%s/no-such-scene.gltf' --frame 1 -o '%s/x.exr'", tmpdir,
             tmpdir);
    PF_CHECK(run_photonfarm(args) == 2);
    PF_CHECK(log_contains("no-such-scene.gltf"));
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x8 -o '%s/no-such-directory/x.exr'", scene, tmpdir);
    /* Refused before the scene is rendered: exit 2, naming the directory, no frame line. */
    int unwritable = run_photonfarm(args);
    PF_CHECK_MSG(unwritable == 2, "unwritable output: exit %d", unwritable);
    PF_CHECK(log_contains("no-such-directory"));
    PF_CHECK(log_contains("output directory"));
    snprintf(args, sizeof args, "render '%s' --frames 1-2 -o '%s/single.exr'", scene, tmpdir);
    PF_CHECK(run_photonfarm(args) == 2);
    PF_CHECK(log_contains("#"));
    /* LPV settings: zero, negative, non-numeric, malformed, beyond the device → exit 2, no file. */
    static const char *const bad_lpv[][2] = {
        {"--lpv-size 0", "--lpv-size"},         {"--lpv-size -8", "--lpv-size"},
        {"--lpv-size abc", "--lpv-size"},       {"--lpv-size 30", "--lpv-size"},
        /* 8 cascades of 256³ cells need 6.4 GB, beyond maxStorageBufferRange (a uint32) of any device. */
        {"--lpv-cascades 8 --lpv-size 256", "--lpv-size"},
        {"--lpv-iterations 0", "--lpv-iterations"},
        {"--lpv-iterations -2", "--lpv-iterations"}, {"--lpv-iterations 8,x", "--lpv-iterations"},
        {"--lpv-iterations 5000", "--lpv-iterations"}, {"--lpv-cascades 0", "--lpv-cascades"},
        {"--lpv-cascades 9", "--lpv-cascades"}, {"--lpv-cell -1", "--lpv-cell"},
        {"--lpv-cell nan", "--lpv-cell"},       {"--photons 0", "--photons"}};
    for (size_t i = 0; i < sizeof bad_lpv / sizeof bad_lpv[0]; i++) {
        snprintf(args, sizeof args,
                 "render '%s' --frame 1 --size 8x8 --quality fast %s -o '%s/lpv.exr'", scene,
                 bad_lpv[i][0], tmpdir);
        char lpv_path[1100];
        snprintf(lpv_path, sizeof lpv_path, "%s/lpv.exr", tmpdir);
        PF_CHECK_MSG(run_photonfarm(args) == 2, "%s", bad_lpv[i][0]);
        PF_CHECK_MSG(log_contains(bad_lpv[i][1]), "%s", bad_lpv[i][0]);
        PF_CHECK_MSG(!file_exists(lpv_path), "%s wrote %s", bad_lpv[i][0], lpv_path);
    }
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x6 --quality final --spp 1 -o '%s/final.exr'", scene,
             tmpdir);
    PF_CHECK(run_photonfarm(args) == 0);
    char final_path[1100];
    snprintf(final_path, sizeof final_path, "%s/final.exr", tmpdir);
    PF_CHECK(file_exists(final_path));
    /* final is denoised by default (issue 40): the EXR says so and keeps the raw beauty. */
    pf_image final_image = {0};
    pf_image_attribute *final_attributes = NULL;
    uint32_t final_attribute_count = 0;
    pf_error final_err = {0};
    PF_CHECK_OK(pf_exr_read(final_path, &final_image, &final_attributes, &final_attribute_count,
                            &final_err),
                &final_err);
    const char *denoised =
        pf_image_attribute_value(final_attributes, final_attribute_count, "photonfarm/denoise");
    PF_CHECK(denoised && !strcmp(denoised, "on"));
    PF_CHECK(pf_image_channel(&final_image, "noisy.R") >= 0 &&
             pf_image_channel(&final_image, "variance.Y") >= 0);
    free(final_attributes);
    pf_image_free(&final_image);
    /*
     * No --quality: auto, whose planner picks fast (no budget) and says so; fast renders with
     * its LPV options, and the EXR names the preset that rendered.
     */
    snprintf(args, sizeof args,
             "render '%s' --frame 1 --size 8x6 --spp 1 --lpv-size 16 "
             "--lpv-iterations 4,4,6,6 --timings -o '%s/fast.exr'",
             scene, tmpdir);
    PF_CHECK(run_photonfarm(args) == 0);
    PF_CHECK(log_contains("lpv_propagate"));
    PF_CHECK(log_contains("auto → fast: no --budget-ms"));
    char fast_path[1100];
    snprintf(fast_path, sizeof fast_path, "%s/fast.exr", tmpdir);
    pf_image fast_image = {0};
    pf_image_attribute *fast_attributes = NULL;
    uint32_t fast_attribute_count = 0;
    pf_error fast_err = {0};
    PF_CHECK_OK(pf_exr_read(fast_path, &fast_image, &fast_attributes, &fast_attribute_count,
                            &fast_err),
                &fast_err);
    const char *preset =
        pf_image_attribute_value(fast_attributes, fast_attribute_count, "photonfarm/preset");
    const char *recorded =
        pf_image_attribute_value(fast_attributes, fast_attribute_count, "photonfarm/settings");
    PF_CHECK(preset && !strcmp(preset, "fast"));
    PF_CHECK(recorded && strstr(recorded, "\"iterations\":[4,4,6,6]") != NULL);
    free(fast_attributes);
    pf_image_free(&fast_image);
    const char *bad_usage[] = {"--frame 1 --frames 1-2", "--frames 5-1", "--frames 1-4x0",
                               "--frame 1 --size 0x3", "--frame 1 --quality best", ""};
    for (size_t i = 0; i < sizeof bad_usage / sizeof bad_usage[0]; i++) {
        snprintf(args, sizeof args, "render '%s' %s -o '%s/u.exr'", scene, bad_usage[i], tmpdir);
        PF_CHECK_MSG(run_photonfarm(args) == 2, "'%s'", bad_usage[i]);
    }
    PF_CHECK(!file_exists("u.exr"));
    PF_CHECK(run_photonfarm("render --help") == 0);
    PF_CHECK(log_contains("--frames RANGE"));
}

int main(void)
{
    pf_test_tmpdir(tmpdir, sizeof tmpdir);
    snprintf(log_path, sizeof log_path, "%s/photonfarm.log", tmpdir);
    PF_RUN(renders_a_frame_range_to_numbered_exr_files);
    PF_RUN(consecutive_frames_reuse_the_one_before);
    PF_RUN(later_layers_are_written_in_place);
    PF_RUN(unusable_cache_directory_warns_and_renders);
    PF_RUN(the_environment_picks_the_device_through_the_cli);
    PF_RUN(bad_frames_scenes_and_options_exit_2);
    return pf_test_finish();
}
