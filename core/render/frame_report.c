/* Stage rows of a frame report (DESIGN.md §4: one row per stage, run or skipped). */
#include "render_internal.h"

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

void pf_traffic_add(pf_vk_traffic *sum, pf_vk_traffic more)
{
    sum->submits += more.submits;
    sum->host_waits += more.host_waits;
    sum->readback_bytes += more.readback_bytes;
    sum->upload_bytes += more.upload_bytes;
    sum->wait_ms += more.wait_ms;
    sum->allocate_ms += more.allocate_ms;
    sum->copy_ms += more.copy_ms;
}

void pf_stage_add_traffic(pf_stage_timing *row, pf_vk_traffic traffic)
{
    pf_stage_add_counter(row, "submits", (double)traffic.submits);
    pf_stage_add_counter(row, "host_waits", (double)traffic.host_waits);
    pf_stage_add_counter(row, "readback_bytes", (double)traffic.readback_bytes);
    pf_stage_add_counter(row, "upload_bytes", (double)traffic.upload_bytes);
    pf_stage_add_counter(row, "wait_ms", traffic.wait_ms);
    pf_stage_add_counter(row, "allocate_ms", traffic.allocate_ms);
    pf_stage_add_counter(row, "copy_ms", traffic.copy_ms);
}

void pf_stage_add_light_samples(pf_stage_timing *row, uint32_t light_count, uint32_t per_vertex)
{
    if (light_count > PF_DIRECT_LIGHTS_EVERY_MAX)
        pf_stage_add_counter(row, "light_samples", per_vertex);
}

pf_stage_timing *pf_frame_report_row(pf_frame_report *report, const char *stage,
                                     const char *skip_reason, double wall_ms, double gpu_ms)
{
    pf_stage_timing *row = pf_frame_report_add(report, stage);
    if (!row)
        return NULL;
    row->wall_ms = wall_ms;
    row->gpu_ms = gpu_ms;
    if (skip_reason) {
        row->skipped = 1;
        snprintf(row->reason, sizeof row->reason, "%s", skip_reason);
    }
    return row;
}

pf_stage_timing *pf_stage_row(pf_frame_report *report, const pf_stage_plan *plan,
                              pf_stage_id stage, double wall_ms, double gpu_ms)
{
    const pf_stage_decision *d = &plan->stages[stage];
    pf_stage_timing *row = pf_frame_report_row(
        report, pf_stage_name(stage), d->action == PF_STAGE_RUN ? NULL : d->reason,
        d->action == PF_STAGE_RUN ? wall_ms : 0.0, d->action == PF_STAGE_RUN ? gpu_ms : -1.0);
    if (row && d->action == PF_STAGE_RUN)
        snprintf(row->reason, sizeof row->reason, "%s", d->reason);
    return row;
}
