/*
 * The EXR layout other tools read (issue 16): every file `photonfarm render`
 * writes is read with OpenEXR's own exrheader (Debian package openexr, path
 * in $EXRHEADER), and its channel list is asserted:
 *   - the beauty is the file's default layer: unprefixed R, G, B, A;
 *   - the AOVs and the lighting split are named layers <layer>.<channel>
 *     (albedo.R, direct.R, ...), OpenEXR's single-part multi-layer naming;
 *   - --no-aovs writes R, G, B, A and nothing else.
 * Rendered with `fast` on the bundled Cornell box at 32 × 24.
 */
#include "pf_image.h"
#include "pf_test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

static char tmpdir[1024];

/* Runs a shell command; its exit code, -1 when it did not exit. */
static int run(const char *command)
{
    int status = system(command);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

#define MAX_CHANNELS 32

/* The channel names exrheader lists for path; returns how many (-1 on failure). */
static int exr_channels(const char *path, char names[MAX_CHANNELS][32])
{
    const char *exrheader = getenv("EXRHEADER");
    char command[2300], listing[1100];
    snprintf(listing, sizeof listing, "%s.header.txt", path);
    snprintf(command, sizeof command, "'%s' '%s' >'%s' 2>&1", exrheader ? exrheader : "exrheader",
             path, listing);
    if (run(command) != 0) {
        fprintf(stderr, "exrheader failed on %s (is the openexr package installed?)\n", path);
        return -1;
    }
    FILE *file = fopen(listing, "r");
    if (!file)
        return -1;
    char line[512];
    int count = 0, in_channels = 0;
    while (fgets(line, sizeof line, file)) {
        if (strncmp(line, "channels (type chlist):", 23) == 0) {
            in_channels = 1;
            continue;
        }
        if (!in_channels)
            continue;
        if (strncmp(line, "    ", 4) != 0)
            break;
        char *name = line + 4, *comma = strchr(name, ',');
        if (!comma || count == MAX_CHANNELS)
            break;
        size_t length = (size_t)(comma - name);
        if (length >= 32)
            break;
        memcpy(names[count], name, length);
        names[count++][length] = '\0';
    }
    fclose(file);
    return count;
}

static int has(char names[MAX_CHANNELS][32], int count, const char *name)
{
    for (int i = 0; i < count; i++) {
        if (strcmp(names[i], name) == 0)
            return 1;
    }
    return 0;
}

/* Renders frame 1 of the bundled Cornell box with fast into out; 1 on success. */
static int render(const char *extra, const char *out)
{
    const char *binary = getenv("PHOTONFARM"), *source = getenv("PF_SOURCE_DIR");
    char command[4096];
    snprintf(command, sizeof command,
             "'%s' render '%s/scenes/cornell/cornell.gltf' --frames 1 --size 32x24 "
             "--quality fast %s --output '%s' >'%s.log' 2>&1",
             binary ? binary : "photonfarm", source ? source : ".", extra, out, out);
    int code = run(command);
    PF_CHECK_MSG(code == 0, "photonfarm render %s exited %d (log %s.log)", extra, code, out);
    return code == 0;
}

PF_TEST(beauty_is_rgba_and_aovs_are_named_layers)
{
    char out[1200];
    snprintf(out, sizeof out, "%s/with-aovs.exr", tmpdir);
    if (!render("", out))
        return;
    char names[MAX_CHANNELS][32];
    int count = exr_channels(out, names);
    PF_REQUIRE(count > 0);
    static const char *const expected[] = {
        "R",          "G",          "B",         "A",         "direct.R",   "direct.G",
        "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
        "caustic.B",  "albedo.R",   "albedo.G",  "albedo.B",  "normal.X",   "normal.Y",
        "normal.Z",   "depth.Z",    "motion.X",  "motion.Y"};
    size_t expected_count = sizeof expected / sizeof expected[0];
    PF_CHECK_MSG(count == (int)expected_count, "%d channels, expected %zu", count, expected_count);
    for (size_t i = 0; i < expected_count; i++)
        PF_CHECK_MSG(has(names, count, expected[i]), "no channel %s", expected[i]);
    /* Every non-beauty channel belongs to a layer: one dot, a name on each side. */
    for (int i = 0; i < count; i++) {
        const char *dot = strchr(names[i], '.');
        int beauty = strlen(names[i]) == 1 && strchr("RGBA", names[i][0]);
        PF_CHECK_MSG(beauty || (dot && dot != names[i] && dot[1] && !strchr(dot + 1, '.')),
                     "channel %s is neither beauty nor <layer>.<channel>", names[i]);
    }
}

PF_TEST(no_aovs_writes_rgba_only)
{
    char out[1200];
    snprintf(out, sizeof out, "%s/no-aovs.exr", tmpdir);
    if (!render("--no-aovs --filter box --max-bounces 2", out))
        return;
    char names[MAX_CHANNELS][32];
    int count = exr_channels(out, names);
    PF_CHECK_MSG(count == 4, "%d channels, expected R, G, B, A", count);
    static const char *const rgba[] = {"R", "G", "B", "A"};
    for (int i = 0; i < 4; i++)
        PF_CHECK_MSG(has(names, count, rgba[i]), "no channel %s", rgba[i]);
}

/* The filter, bounce limit and denoising are in the metadata; compare warns about differing
 * filters. */
PF_TEST(filter_and_bounces_are_recorded_and_compared)
{
    char with[1200], without[1200], command[4096], log[1300];
    snprintf(with, sizeof with, "%s/with-aovs.exr", tmpdir);
    snprintf(without, sizeof without, "%s/no-aovs.exr", tmpdir);
    pf_image image = {0};
    pf_image_attribute *attributes = NULL;
    uint32_t count = 0;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_exr_read(without, &image, &attributes, &count, &err), &err);
    const char *filter = pf_image_attribute_value(attributes, count, "photonfarm/pixelFilter");
    const char *bounces = pf_image_attribute_value(attributes, count, "photonfarm/maxBounces");
    const char *denoise = pf_image_attribute_value(attributes, count, "photonfarm/denoise");
    /* fast is not denoised unless asked (issue 40's auto). */
    PF_CHECK_MSG(denoise && !strcmp(denoise, "off"), "denoise %s", denoise ? denoise : "missing");
    PF_CHECK_MSG(filter && !strcmp(filter, "box"), "pixelFilter %s", filter ? filter : "missing");
    PF_CHECK_MSG(bounces && !strcmp(bounces, "2"), "maxBounces %s", bounces ? bounces : "missing");
    free(attributes);
    pf_image_free(&image);
    const char *binary = getenv("PHOTONFARM");
    snprintf(log, sizeof log, "%s/compare.log", tmpdir);
    snprintf(command, sizeof command, "'%s' compare --rgb '%s' '%s' >'%s' 2>&1",
             binary ? binary : "photonfarm", with, without, log);
    PF_CHECK(run(command) == 0);
    FILE *file = fopen(log, "r");
    PF_REQUIRE(file != NULL);
    char text[8192] = {0};
    size_t length = fread(text, 1, sizeof text - 1, file);
    fclose(file);
    text[length] = '\0';
    PF_CHECK_MSG(strstr(text, "warning: different pixel filters") && strstr(text, "gaussian") &&
                     strstr(text, "box"),
                 "compare printed:\n%s", text);
}

int main(void)
{
    pf_test_tmpdir(tmpdir, sizeof tmpdir);
    PF_RUN(beauty_is_rgba_and_aovs_are_named_layers);
    PF_RUN(no_aovs_writes_rgba_only);
    PF_RUN(filter_and_bounces_are_recorded_and_compared);
    return pf_test_finish();
}
