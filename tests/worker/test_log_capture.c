/*
 * The worker's capture of an attempt's log lines (worker/log.c, issue 41): every line
 * while it is short; past PF_WLOG_CAPTURE_MAX the first lines and the last, with one line
 * saying how many were left out between, and nothing outside a capture. A line about
 * another attempt (pf_wlog_about) stays out of the running capture and is kept for its own.
 */
#include "log.h"
#include "pf_test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int count_of(const char *text, const char *part)
{
    int count = 0;
    for (const char *at = strstr(text, part); at; at = strstr(at + 1, part))
        count++;
    return count;
}

PF_TEST(a_short_attempt_keeps_every_line)
{
    pf_wlog(PF_LOG_INFO, "before", "outside=1");
    pf_wlog_capture_begin(NULL);
    for (int i = 0; i < 10; i++)
        pf_wlog(PF_LOG_INFO, "step", "n=%d", i);
    char *text = pf_wlog_capture_end();
    PF_REQUIRE(text != NULL);
    PF_CHECK(count_of(text, "event=step") == 10 && count_of(text, "\n") == 10);
    PF_CHECK(strstr(text, "n=0\n") && strstr(text, "n=9\n") && !strstr(text, "outside"));
    PF_CHECK(!strstr(text, "left out"));
    free(text);
    pf_wlog(PF_LOG_INFO, "after", "outside=2");
    PF_CHECK(pf_wlog_capture_end() == NULL); /* none running */
}

PF_TEST(a_long_attempt_keeps_its_first_and_last_lines)
{
    enum { LINES = 5000 };
    pf_wlog_capture_begin(NULL);
    for (int i = 0; i < LINES; i++)
        pf_wlog(PF_LOG_INFO, "step", "n=%05d padding=%080d", i, 0);
    char *text = pf_wlog_capture_end();
    PF_REQUIRE(text != NULL);
    size_t length = strlen(text);
    PF_CHECK_MSG(length <= PF_WLOG_CAPTURE_MAX && length > PF_WLOG_CAPTURE_MAX / 2,
                 "%zu bytes kept", length);
    PF_CHECK(strstr(text, "n=00000 ") != NULL && strstr(text, "n=04999 ") != NULL);
    const char *marker = strstr(text, "... ");
    PF_REQUIRE(marker != NULL);
    int left_out = atoi(marker + 4);
    int kept = count_of(text, "event=step");
    PF_CHECK_MSG(kept + left_out == LINES, "%d kept + %d left out != %d", kept, left_out, LINES);
    /* The marker sits between the first lines and the last: before it n=00000, after it
     * n=04999, and the lines on each side are consecutive. */
    PF_CHECK(strstr(text, "n=00000 ") < marker && strstr(text, "n=04999 ") > marker);
    free(text);
}

/* The worker renders task B while task A's frames are written: A's lines go to A's late
 * lines, not into B's capture; B's own and unattributed lines into B's. */
PF_TEST(a_line_about_another_attempt_stays_out_of_the_capture)
{
    int a = 0, b = 0; /* the attempts' identities: their addresses */
    pf_wlog_late late_a = {0}, late_b = {0};
    pf_wlog_capture_begin(&b);
    pf_wlog_about(&a, &late_a, PF_LOG_INFO, "written", "task=a frame=1");
    pf_wlog_about(&b, &late_b, PF_LOG_INFO, "rendered", "task=b");
    pf_wlog(PF_LOG_INFO, "core", "message=shared");
    pf_wlog_about(&a, NULL, PF_LOG_INFO, "completed", "task=a");
    char *text = pf_wlog_capture_end();
    PF_REQUIRE(text != NULL);
    PF_CHECK(strstr(text, "task=b") && strstr(text, "message=shared"));
    PF_CHECK(!strstr(text, "task=a"));
    char *a_lines = pf_wlog_late_take(&late_a);
    PF_REQUIRE(a_lines != NULL);
    PF_CHECK(count_of(a_lines, "\n") == 1 && strstr(a_lines, "event=written task=a frame=1\n"));
    PF_CHECK(pf_wlog_late_take(&late_a) == NULL && pf_wlog_late_take(&late_b) == NULL);
    /* Past PF_WLOG_LATE_MAX the lines are counted, not kept. */
    for (int i = 0; i < 500; i++)
        pf_wlog_about(&a, &late_a, PF_LOG_INFO, "written", "task=a frame=%d padding=%040d", i,
                      0);
    char *many = pf_wlog_late_take(&late_a);
    PF_REQUIRE(many != NULL);
    const char *marker = strstr(many, "... ");
    PF_REQUIRE(marker != NULL);
    int kept = count_of(many, "event=written"), left_out = atoi(marker + 4);
    PF_CHECK_MSG(kept + left_out == 500 && strlen(many) <= PF_WLOG_LATE_MAX + 64,
                 "%d kept + %d left out, %zu bytes", kept, left_out, strlen(many));
    free(many);
    free(a_lines);
    free(text);
}

int main(void)
{
    /* The lines go to stderr too: keep the test's output short. */
    if (!freopen("/dev/null", "w", stderr))
        return 1;
    PF_RUN(a_short_attempt_keeps_every_line);
    PF_RUN(a_long_attempt_keeps_its_first_and_last_lines);
    PF_RUN(a_line_about_another_attempt_stays_out_of_the_capture);
    return pf_test_finish();
}
