// The shading kernels' ray counter (render_final.comp, final_gather.comp,
// render_fast.comp, render_reference.comp, render_reference_wave_tail.comp):
// the including shader declares counters.rays_low and counters.rays_high, a
// 64-bit count in two 32-bit words.
#ifndef PF_RAY_COUNT_GLSL
#define PF_RAY_COUNT_GLSL

// Adds rays to the 64-bit ray counter (two 32-bit words).
void count_rays(uint rays)
{
    uint previous_low = atomicAdd(counters.rays_low, rays);
    if (previous_low + rays < previous_low)
        atomicAdd(counters.rays_high, 1u);
}

#endif
