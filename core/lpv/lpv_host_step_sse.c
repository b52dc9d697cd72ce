/*
 * A host propagation iteration 4 lanes a vector: x86-64's SSE2 baseline, or
 * any target (lpv_host_step_body.h).
 */
#define STEP_WIDTH 4
#define STEP_NAME pf_lpv_host_step_4
#include "lpv_host_step_body.h"
