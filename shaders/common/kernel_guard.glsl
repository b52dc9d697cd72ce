// Loop-cap proof for the kernels whose loops can add up to llvmpipe's cap
// (the final kernels, render_fast.comp, photon_trace.comp, the reference
// kernels). The including shader declares push.loop_sentinel (always 1).
//
// Loop cap (lavapipe): llvmpipe ends every loop of an invocation once all its
// loops together have gone round 65,535 times, silently: gallivm counts each
// loop's back-edges in one counter per invocation (8 lanes) and leaves the loop
// there once it has run out. loops_completed(), called at the very end of an
// invocation, runs a loop that must go round twice (its bound a push constant,
// so no compiler can count it): after the cap it leaves at its first back-edge,
// after one round, so it returns false. A loop of one round proves nothing (its
// body runs before its first back-edge, cap or not: this guard's first version,
// which never fired), nor did a do-while of two (it went round twice after the
// cap); a probe kernel spinning 70,000 rounds first measured both.
#ifndef PF_KERNEL_GUARD_GLSL
#define PF_KERNEL_GUARD_GLSL

bool loops_completed()
{
    uint rounds = 0u;
    for (uint i = 0u; i <= push.loop_sentinel; i++)
        rounds++;
    return rounds > push.loop_sentinel;
}

#endif
