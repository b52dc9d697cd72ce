// Loop-cap proof and ray counting shared by the shading kernels that run
// photon estimates (render_final.comp, render_fast.comp). The including
// shader declares push.loop_sentinel (always 1) and counters.rays_low /
// counters.rays_high.
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

// Adds rays to the 64-bit ray counter (two 32-bit words).
void count_rays(uint rays)
{
    uint previous_low = atomicAdd(counters.rays_low, rays);
    if (previous_low + rays < previous_low)
        atomicAdd(counters.rays_high, 1u);
}

#endif
