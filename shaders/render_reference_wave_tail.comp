#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The reference wavefront's tail (reference_wave.glsl says the whole):
// WAVE_TAIL, the last paths of a slice run to their ends on the device, in a
// module of its own (it traces: the shade module without it is smaller to
// build, and a frame without a tail never builds this one).

#include "reference_wave.glsl"

// WAVE_TAIL: every lane runs paths to their ends, taking the next from tail.next until
// none is left or it has shaded TAIL_LANE_VERTICES vertices: llvmpipe ends every loop of an
// invocation once all of them together have gone round 65,535 times (gallivm's loop
// limiter: the paths would end short, silently), so a lane must not run an unbounded share
// of the list. With the bound, a lane runs at most TAIL_LANE_VERTICES + params.max_path_depth
// vertices, 1.5 times the megakernel's own worst case. tail.next ends past the paths taken:
// the host runs the tail again for any left, and fails the frame if a path it was given is
// still queued (cut short).
// The loop's shape matters to the image: the megakernel's and the wave's vertex code round
// alike here (test_trace_site compares them bit for bit); a lane a path, with the hit's
// vertex before the loop, rounded otherwise in hundreds of pixels (llvmpipe fuses a·b + c
// where the product has one use, and what has one use depends on the code around it).
const uint TAIL_LANE_VERTICES = 32u;
void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uint p = 0u, vertices = 0u, rays = 0u;
    bool holding = false; // a path whose next vertex is this lane's to shade
    for (;;) {
        BihHit hit = BihHit(-1.0, NO_HIT, 0.0, 0.0);
        if (!holding) {
            if (vertices >= TAIL_LANE_VERTICES)
                break;
            uint next = atomicAdd(tail.next, 1u);
            if (next >= push.count)
                break;
            p = texelFetch(active_paths, int(push.first_active + next)).x;
            wave_shadow_base = p * direct_light_slots();
            if (path_resume(p, pixel_of(p)))
                hit = traced_hit(p);
        } else {
            hit = trace_seen(path_origin, path_direction, infinity, false, path_depth == 0u);
            path_rays++;
        }
        tail_unoccluded = vec3(0.0);
        holding = path_vertex(hit);
        vertices++;
        path_add(tail_unoccluded, path_shadow_region, false);
        if (cut_at_loop_cap())
            holding = false; // and every loop ends from here: this lane takes no more paths
        if (!holding) {
            path_store(p);
            queue[p] = 0u; // ended, nothing left to trace: the finish adds no shadow rays
            rays += path_rays;
        }
    }
    count_rays(rays);
}
