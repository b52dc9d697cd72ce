/* Whose fault a failed frame is, and a task's temporaries (frame_fault.h). */
#include "frame_fault.h"

#include <inttypes.h>
#include <stdio.h>

const char *pf_frame_fault_name(pf_frame_fault fault)
{
    switch (fault) {
    case PF_FRAME_FAULT_SCENE:
        return "scene";
    case PF_FRAME_FAULT_SETTINGS:
        return "settings";
    case PF_FRAME_FAULT_OUTPUT:
        return "output";
    case PF_FRAME_FAULT_REFUSED:
        return "refused";
    default:
        return "worker";
    }
}

pf_frame_fault pf_frame_fault_of(pf_frame_failure failed)
{
    switch (failed) {
    case PF_FRAME_FAILED_SCENE:
        return PF_FRAME_FAULT_SCENE;
    case PF_FRAME_FAILED_OUTPUT:
        return PF_FRAME_FAULT_OUTPUT;
    default:
        return PF_FRAME_FAULT_WORKER;
    }
}

void pf_frame_task_tag(int64_t task_id, const char *lease_token, char *out, size_t size)
{
    snprintf(out, size, "t%" PRId64 "-%s", task_id, lease_token ? lease_token : "");
}

int pf_frame_remove_stale(const char *output_path, int64_t task_id)
{
    char prefix[32];
    snprintf(prefix, sizeof prefix, "t%" PRId64 "-", task_id);
    return pf_frame_remove_partials(output_path, prefix);
}
