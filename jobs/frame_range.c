/* Frame range text ("1-48", "1-48x2", "1,5,9-12") to a sorted list of frames. */
#include "pf_queue.h"

#include <ctype.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

typedef struct range_item {
    const char *text; /* start of the item in the range text */
    int length;
    int64_t first, last, step;
} range_item;

typedef struct tagged_frame {
    int32_t frame;
    uint32_t item;
} tagged_frame;

static bool is_blank(char c) { return c == ' ' || c == '\t'; }

/* Parses a decimal number of digits only at *cursor (no sign: frames and steps
 * are never negative), advancing the cursor. */
static bool parse_number(const char **cursor, const char *end, int64_t *value)
{
    const char *p = *cursor;
    int64_t number = 0;
    if (p >= end || !isdigit((unsigned char)*p))
        return false;
    while (p < end && isdigit((unsigned char)*p)) {
        number = number * 10 + (*p - '0');
        if (number > PF_FRAME_NUMBER_MAX)
            number = PF_FRAME_NUMBER_MAX + 1; /* saturate: reported as too large */
        p++;
    }
    *cursor = p;
    *value = number;
    return true;
}

static pf_status item_error(pf_error *err, const char *range, const range_item *item,
                            const char *problem)
{
    return pf_error_set(err, PF_ERR_INVALID, "frame range \"%s\": item \"%.*s\": %s", range,
                        item->length, item->text, problem);
}

static pf_status parse_item(const char *range, range_item *item, pf_error *err)
{
    const char *p = item->text, *end = item->text + item->length;
    if (item->length == 0)
        return pf_error_set(err, PF_ERR_INVALID,
                            "frame range \"%s\": empty item (stray or doubled comma)", range);
    if (!parse_number(&p, end, &item->first))
        return item_error(err, range, item,
                          *p == '-' ? "frame numbers cannot be negative"
                                    : "expected a frame number like 12, 1-48 or 1-48x2");
    item->last = item->first;
    item->step = 1;
    if (p < end && *p == '-') {
        p++;
        if (!parse_number(&p, end, &item->last))
            return item_error(err, range, item, "expected the last frame after '-'");
        if (p < end && (*p == 'x' || *p == 'X')) {
            p++;
            if (!parse_number(&p, end, &item->step))
                return item_error(err, range, item,
                                  "the step after 'x' must be a positive whole number");
            if (item->step == 0)
                return item_error(err, range, item, "the step must be at least 1");
        }
    }
    if (p != end)
        return item_error(err, range, item, "unexpected text after the frames");
    if (item->first > PF_FRAME_NUMBER_MAX || item->last > PF_FRAME_NUMBER_MAX ||
        item->step > PF_FRAME_NUMBER_MAX)
        return item_error(err, range, item, "number larger than 999999999");
    if (item->last < item->first)
        return item_error(err, range, item, "reversed range (last frame before first)");
    return PF_OK;
}

static int compare_tagged(const void *a, const void *b)
{
    const tagged_frame *x = a, *y = b;
    return (x->frame > y->frame) - (x->frame < y->frame);
}

void pf_frame_list_free(pf_frame_list *list)
{
    if (!list)
        return;
    free(list->frames);
    list->frames = NULL;
    list->count = 0;
}

pf_status pf_frame_range_parse(const char *text, pf_frame_list *out, pf_error *err)
{
    out->frames = NULL;
    out->count = 0;
    if (!text)
        text = "";
    size_t item_count = 1;
    for (const char *p = text; *p; p++)
        item_count += *p == ',';
    bool all_blank = true;
    for (const char *p = text; *p; p++)
        all_blank = all_blank && is_blank(*p);
    if (all_blank)
        return pf_error_set(err, PF_ERR_INVALID, "frame range is empty");

    range_item *items = calloc(item_count, sizeof *items);
    if (!items)
        return pf_error_set(err, PF_ERR_NOMEM, "frame range \"%s\": out of memory", text);
    pf_status status = PF_OK;
    const char *start = text;
    uint64_t total = 0;
    for (size_t i = 0; i < item_count && status == PF_OK; i++) {
        const char *end = strchr(start, ',');
        if (!end)
            end = start + strlen(start);
        const char *next = *end ? end + 1 : end;
        while (start < end && is_blank(*start))
            start++;
        while (end > start && is_blank(end[-1]))
            end--;
        items[i].text = start;
        items[i].length = (int)(end - start);
        status = parse_item(text, &items[i], err);
        if (status == PF_OK) {
            total += (uint64_t)((items[i].last - items[i].first) / items[i].step + 1);
            if (total > PF_FRAME_RANGE_MAX_FRAMES)
                status = pf_error_set(err, PF_ERR_INVALID,
                                      "frame range \"%s\": more than %d frames", text,
                                      PF_FRAME_RANGE_MAX_FRAMES);
        }
        start = next;
    }

    tagged_frame *tagged = NULL;
    if (status == PF_OK && !(tagged = malloc(total * sizeof *tagged)))
        status = pf_error_set(err, PF_ERR_NOMEM, "frame range \"%s\": out of memory", text);
    if (status == PF_OK) {
        size_t n = 0;
        for (size_t i = 0; i < item_count; i++)
            for (int64_t f = items[i].first; f <= items[i].last; f += items[i].step)
                tagged[n++] = (tagged_frame){(int32_t)f, (uint32_t)i};
        qsort(tagged, total, sizeof *tagged, compare_tagged);
        for (size_t k = 1; k < total && status == PF_OK; k++) {
            if (tagged[k].frame != tagged[k - 1].frame)
                continue;
            const range_item *a = &items[tagged[k - 1].item], *b = &items[tagged[k].item];
            status = pf_error_set(err, PF_ERR_INVALID,
                                  "frame range \"%s\": frame %d is listed twice (items \"%.*s\" "
                                  "and \"%.*s\" overlap)",
                                  text, tagged[k].frame, a->length, a->text, b->length, b->text);
        }
    }
    if (status == PF_OK && !(out->frames = malloc(total * sizeof *out->frames)))
        status = pf_error_set(err, PF_ERR_NOMEM, "frame range \"%s\": out of memory", text);
    if (status == PF_OK) {
        for (size_t k = 0; k < total; k++)
            out->frames[k] = tagged[k].frame;
        out->count = total;
    }
    free(tagged);
    free(items);
    return status;
}
