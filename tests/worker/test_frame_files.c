/*
 * The frame pipeline's files: a task's stale temporaries are removed before
 * it renders again, and nothing else is (another task's temporary, a finished
 * frame, another output's files); the output check refuses a missing
 * directory and a # in a directory name before anything renders.
 */
#include "frame_fault.h"
#include "pf_render.h"
#include "pf_test.h"
#include "worker_test_util.h"

#include <string.h>

static void touch(const char *dir, const char *name)
{
    char path[WT_PATH_MAX + 128];
    wt_format(path, sizeof path, "%s/%s", dir, name);
    FILE *file = fopen(path, "wb");
    PF_REQUIRE(file);
    fputs("x", file);
    fclose(file);
}

PF_TEST(stale_cleanup_touches_only_its_own_task)
{
    char dir[WT_PATH_MAX], output[WT_PATH_MAX + 64], tag[96];
    wt_fresh_dir("stale", dir, sizeof dir);
    pf_frame_task_tag(7, "abc", tag, sizeof tag);
    PF_CHECK(!strcmp(tag, "t7-abc"));
    touch(dir, "f.0001.exr.partial-t7-oldlease");      /* task 7's earlier attempt */
    touch(dir, "f.0001.exr.partial-t7-older.tmp-1-2"); /* and pf_exr_write's temporary */
    touch(dir, "f.0001.exr.partial-t71-lease");        /* task 71: another task */
    touch(dir, "f.0001.exr.partial-t8-lease");         /* another job's task, same file */
    touch(dir, "f.0001.exr");                          /* a finished frame */
    touch(dir, "f.0002.exr.partial-t7-lease");         /* task 7's other frame */
    wt_format(output, sizeof output, "%s/f.0001.exr", dir);
    PF_CHECK(pf_frame_remove_stale(output, 7) == 2);
    PF_CHECK(wt_count_files(dir, "partial-t7-") == 1); /* f.0002's stays */
    PF_CHECK(wt_count_files(dir, "partial-t71-") == 1);
    PF_CHECK(wt_count_files(dir, "partial-t8-") == 1);
    PF_CHECK(wt_count_files(dir, "") == 4);
}

PF_TEST(output_check_refuses_before_rendering)
{
    char dir[WT_PATH_MAX], pattern[WT_PATH_MAX + 64], absolute[4096];
    pf_error err = {0};
    wt_fresh_dir("output-check", dir, sizeof dir);
    wt_format(pattern, sizeof pattern, "%s/missing/f.####.exr", dir);
    PF_CHECK(pf_frame_output_check(pattern, absolute, sizeof absolute, &err) == PF_ERR_IO);
    PF_CHECK(strstr(err.message, "missing") != NULL);
    wt_format(pattern, sizeof pattern, "%s/##/f.exr", dir);
    PF_CHECK(pf_frame_output_check(pattern, absolute, sizeof absolute, &err) == PF_ERR_INVALID);
    wt_format(pattern, sizeof pattern, "%s/", dir);
    PF_CHECK(pf_frame_output_check(pattern, absolute, sizeof absolute, &err) == PF_ERR_INVALID);
    wt_format(pattern, sizeof pattern, "%s/./f.####.exr", dir);
    PF_CHECK_OK(pf_frame_output_check(pattern, absolute, sizeof absolute, &err), &err);
    PF_CHECK(absolute[0] == '/' && strstr(absolute, "/./") == NULL);
    PF_CHECK(wt_count_files(dir, "probe") == 0); /* the probe file is gone */
}

PF_TEST(frames_too_large_for_memory_are_refused)
{
    pf_error err = {0};
    const uint64_t gib = 1ull << 30;
    /* 16384 x 16384 x 88 bytes = 22 GiB: refused with 12 GiB, allowed with 32 GiB. */
    PF_CHECK(pf_frame_memory_check(16384, 16384, 12 * gib, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "16384x16384") && strstr(err.message, "GiB"));
    PF_CHECK_OK(pf_frame_memory_check(16384, 16384, 32 * gib, &err), &err);
    PF_CHECK_OK(pf_frame_memory_check(640, 480, 12 * gib, &err), &err);
    /* The machine's own limit admits an ordinary frame. */
    PF_CHECK_OK(pf_frame_memory_check(1920, 1080, 0, &err), &err);
}

int main(void)
{
    PF_RUN(frames_too_large_for_memory_are_refused);
    PF_RUN(stale_cleanup_touches_only_its_own_task);
    PF_RUN(output_check_refuses_before_rendering);
    return pf_test_finish();
}
