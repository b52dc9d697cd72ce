/*
 * A host propagation iteration 8 lanes a vector (lpv_host_step_body.h),
 * built with -mavx2 (but no -mfma: the same IEEE operations as the 4-wide
 * build, so the same answers). Only called where the CPU reports AVX2
 * (lpv_propagate_host.c).
 */
#define STEP_WIDTH 8
#define STEP_NAME pf_lpv_host_step_8
#include "lpv_host_step_body.h"
