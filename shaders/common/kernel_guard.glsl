// Loop-cap proof for the kernels whose loops can add up to llvmpipe's cap
// (the final kernels, render_fast.comp, photon_trace.comp). The including
// shader declares push.loop_sentinel (always 1).
//
// Loop cap (lavapipe): llvmpipe ends every loop of an invocation after
// 65,535 iterations in total, silently. loops_completed(), called at the
// very end of an invocation, runs one iteration of a loop bounded by a push
// constant: after the cap that loop runs zero times, so it returns false.
#ifndef PF_KERNEL_GUARD_GLSL
#define PF_KERNEL_GUARD_GLSL

bool loops_completed()
{
    bool completed = false;
    for (uint i = 0u; i < push.loop_sentinel; i++)
        completed = true;
    return completed;
}

#endif
