/* Frame range parsing: the syntax, and every kind of bad input with its message. */
#include "pf_queue.h"
#include "pf_test.h"

static void check_frames(const char *text, const int32_t *expected, size_t count)
{
    pf_frame_list list;
    pf_error err = {0};
    pf_status status = pf_frame_range_parse(text, &list, &err);
    PF_CHECK_MSG(status == PF_OK, "\"%s\": %s", text, err.message);
    PF_CHECK_MSG(list.count == count, "\"%s\": %zu frames, expected %zu", text, list.count, count);
    for (size_t i = 0; i < count && i < list.count; i++)
        PF_CHECK_MSG(list.frames[i] == expected[i], "\"%s\" frame %zu: %d, expected %d", text, i,
                     list.frames[i], expected[i]);
    pf_frame_list_free(&list);
}

/* Parsing must fail with PF_ERR_INVALID and a message containing needle. */
static void check_rejected(const char *text, const char *needle)
{
    pf_frame_list list;
    pf_error err = {0};
    pf_status status = pf_frame_range_parse(text, &list, &err);
    PF_CHECK_MSG(status == PF_ERR_INVALID, "\"%s\" accepted (status %d)", text, status);
    PF_CHECK_MSG(strstr(err.message, needle) != NULL, "\"%s\": message \"%s\" lacks \"%s\"",
                 text ? text : "(null)", err.message, needle);
    PF_CHECK(list.count == 0 && list.frames == NULL);
    pf_frame_list_free(&list);
}

PF_TEST(single_frames_and_ranges)
{
    check_frames("7", (int32_t[]){7}, 1);
    check_frames("0", (int32_t[]){0}, 1);
    check_frames("1-4", (int32_t[]){1, 2, 3, 4}, 4);
    check_frames("3-3", (int32_t[]){3}, 1);
    check_frames("1-9x2", (int32_t[]){1, 3, 5, 7, 9}, 5);
    /* The step need not land on the last frame. */
    check_frames("1-10x4", (int32_t[]){1, 5, 9}, 3);
    check_frames("1,5,9-12", (int32_t[]){1, 5, 9, 10, 11, 12}, 6);
    /* Items in any order come back sorted; blanks around items are fine. */
    check_frames(" 20 , 3-4 ,1", (int32_t[]){1, 3, 4, 20}, 4);
    /* Interleaved steps are not overlaps. */
    check_frames("1-9x2,2-10x2", (int32_t[]){1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, 10);
}

PF_TEST(large_range_counts)
{
    pf_frame_list list;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_frame_range_parse("1-48x2", &list, &err), &err);
    PF_CHECK(list.count == 24);
    PF_CHECK(list.frames[23] == 47);
    pf_frame_list_free(&list);
    PF_REQUIRE_OK(pf_frame_range_parse("1-100000", &list, &err), &err);
    PF_CHECK(list.count == 100000);
    PF_CHECK(list.frames[99999] == 100000);
    pf_frame_list_free(&list);
}

PF_TEST(bad_ranges)
{
    check_rejected("", "empty");
    check_rejected("   ", "empty");
    check_rejected(NULL, "empty");
    check_rejected("1,,2", "empty item");
    check_rejected("1,", "empty item");
    check_rejected("abc", "\"abc\"");
    check_rejected("10-1", "reversed");
    check_rejected("1-10x0", "at least 1");
    check_rejected("1-10x-2", "positive");
    check_rejected("-5", "negative");
    check_rejected("1-", "last frame");
    check_rejected("1-5y2", "unexpected");
    check_rejected("1.5", "unexpected");
    check_rejected("1-10,5", "frame 5 is listed twice");
    check_rejected("1-10,8-12", "overlap");
    check_rejected("3,3", "listed twice");
    check_rejected("1-1000000000", "larger than");
    check_rejected("99999999999999999999999", "larger than");
    /* Bounded: 1,000,001 frames are refused before any allocation of that size. */
    check_rejected("0-1000000", "more than 1000000 frames");
    check_rejected("0-600000,600001-1200000", "more than");
}

int main(void)
{
    PF_RUN(single_frames_and_ranges);
    PF_RUN(large_range_counts);
    PF_RUN(bad_ranges);
    return pf_test_finish();
}
