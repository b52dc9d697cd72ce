/* Stage rows of a frame report (DESIGN.md §4: one row per stage, run or skipped). */
#include "pf_render.h"

#include <stdio.h>
#include <string.h>

pf_stage_timing *pf_frame_report_add(pf_frame_report *report, const char *stage)
{
    if (!report || report->stage_count >= PF_FRAME_STAGES_MAX)
        return NULL;
    pf_stage_timing *row = &report->stages[report->stage_count++];
    memset(row, 0, sizeof *row);
    snprintf(row->stage, sizeof row->stage, "%s", stage);
    row->gpu_ms = -1.0;
    return row;
}

void pf_stage_add_counter(pf_stage_timing *stage, const char *name, double value)
{
    if (!stage || stage->counter_count >= PF_STAGE_COUNTERS_MAX)
        return;
    pf_stage_counter *counter = &stage->counters[stage->counter_count++];
    snprintf(counter->name, sizeof counter->name, "%s", name);
    counter->value = value;
}
