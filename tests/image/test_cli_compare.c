/* `photonfarm compare`: exit codes and the numbers it prints, on files made here. */
#include "pf_image.h"
#include "pf_test.h"

#include <sys/wait.h>

static char tmp_dir[512];

/* Runs "$PHOTONFARM compare <arguments> 2>&1"; returns the exit code, output in buffer. */
static int run_compare(const char *arguments, char *output, size_t size)
{
    const char *binary = getenv("PHOTONFARM");
    char command[2048];
    snprintf(command, sizeof command, "'%s' compare %s 2>&1", binary ? binary : "photonfarm",
             arguments);
    FILE *pipe = popen(command, "r");
    if (!pipe)
        return -1;
    size_t length = fread(output, 1, size - 1, pipe);
    output[length] = '\0';
    int status = pclose(pipe);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static void write_constant(const char *name, uint32_t width, uint32_t height, float value,
                           char *path, size_t size)
{
    static const char *const rgba[] = {"R", "G", "B", "A"};
    snprintf(path, size, "%s/%s", tmp_dir, name);
    pf_error err = {0};
    pf_image image;
    PF_REQUIRE_OK(pf_image_create(&image, width, height, 4, rgba, &err), &err);
    for (size_t i = 0; i < (size_t)width * height * 4; i++)
        image.pixels[i] = value;
    PF_CHECK_OK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err), &err);
    pf_image_free(&image);
}

PF_TEST(identical_and_offset_files)
{
    char a[600], b[600], c[600], arguments[2000], output[8192];
    write_constant("a.exr", 9, 5, 0.5f, a, sizeof a);
    write_constant("b.exr", 9, 5, 0.5f, b, sizeof b);
    write_constant("c.exr", 9, 5, 0.75f, c, sizeof c);

    snprintf(arguments, sizeof arguments, "'%s' '%s'", a, b);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 0);
    PF_CHECK_MSG(strstr(output, "RMSE:          0\n") != NULL, "output:\n%s", output);
    PF_CHECK_MSG(strstr(output, "max abs error: 0\n") != NULL, "output:\n%s", output);

    snprintf(arguments, sizeof arguments, "'%s' '%s' --format json", c, a);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 0);
    /* 0.75 vs 0.5: RMSE = max = 0.25, relMSE = 0.0625 / (0.25 + 0.01). */
    PF_CHECK_MSG(strstr(output, "\"rmse\": 0.25,") != NULL, "output:\n%s", output);
    PF_CHECK_MSG(strstr(output, "\"max_abs_error\": 0.25,") != NULL, "output:\n%s", output);
    char relmse[64];
    snprintf(relmse, sizeof relmse, "\"relmse\": %.9g,", 0.0625 / (0.25 + PF_RELMSE_EPSILON));
    PF_CHECK_MSG(strstr(output, relmse) != NULL, "expected %s in:\n%s", relmse, output);
    PF_CHECK_MSG(strstr(output, "{\"name\": \"R\", \"mean_a\": 0.75, \"mean_b\": 0.5}") != NULL,
                 "output:\n%s", output);
}

PF_TEST(mismatch_and_missing_file_exit_2)
{
    char a[600], small[600], missing[600], arguments[2000], output[8192];
    write_constant("a.exr", 9, 5, 0.5f, a, sizeof a);
    write_constant("small.exr", 4, 4, 0.5f, small, sizeof small);
    snprintf(missing, sizeof missing, "%s/missing.exr", tmp_dir);

    snprintf(arguments, sizeof arguments, "'%s' '%s'", a, small);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 2);
    PF_CHECK_MSG(strstr(output, "9x5") && strstr(output, "4x4"), "output:\n%s", output);

    snprintf(arguments, sizeof arguments, "'%s' '%s'", a, missing);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 2);
    PF_CHECK_MSG(strstr(output, missing) != NULL, "output:\n%s", output);

    snprintf(arguments, sizeof arguments, "'%s'", a);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 2);
    snprintf(arguments, sizeof arguments, "'%s' '%s' --format xml", a, a);
    PF_CHECK(run_compare(arguments, output, sizeof output) == 2);
    PF_CHECK(run_compare("--help", output, sizeof output) == 0);
    PF_CHECK(strstr(output, "usage: photonfarm compare") != NULL);
}

int main(void)
{
    pf_test_tmpdir(tmp_dir, sizeof tmp_dir);
    PF_RUN(identical_and_offset_files);
    PF_RUN(mismatch_and_missing_file_exit_2);
    return pf_test_finish();
}
