// Rays of the shade kernels that the host traces where the device is the CPU
// (issue 43; core/render/host_rays.c): the camera rays of final's primary
// (render_final.comp) and final's gather rays' first segments
// (final_gather.glsl). Nearly every such ray ends its path
// segment at its first hit, and the host's wide AVX2 traversal on every core
// traces several times faster than this device's GLSL loop. TRACE_STEP
// (constant_id 0) says who traces them:
//   TRACED_HERE  the kernel, as ever (a GPU's: its traversal is the one to use);
//   WRITE_RAYS   the kernel writes the rays into host_rays, nothing else;
//   HITS_GIVEN   the kernel runs, reading those rays' hits from host_hits
//                (going on past a hit that an alpha test says does not count:
//                scene_trace.glsl trace_after); rays after them (specular
//                chains, shadow rays) it traces.
// The kernel computes a ray the same way in both steps, from the same random
// numbers, so the image is the device's but for ties between equally
// distant triangles. The kernels run over bands of push.row_first on, so the
// queue stays bounded; host_queue[slot] is 1 where the slot holds a ray.
// The including kernel declares its Push with a uint row_first, defines
// HOST_RAYS_BINDING (the first of the queue's three bindings) and includes
// scene_bindings.glsl first, and scene_trace.glsl where it reads hits
// (host_hit: the kernels that read hits trace rays of their own as well).
// camera_rays.comp writes the camera rays for final's primary.
#ifndef PF_HOST_RAYS_GLSL
#define PF_HOST_RAYS_GLSL

#include "ray_types.glsl"

const uint TRACED_HERE = 0u;
const uint WRITE_RAYS = 1u;
const uint HITS_GIVEN = 2u;
layout(constant_id = 0) const uint TRACE_STEP = TRACED_HERE;

layout(std430, set = 0, binding = HOST_RAYS_BINDING + 0) writeonly buffer HostRays { Ray host_rays[]; };
layout(set = 0, binding = HOST_RAYS_BINDING + 1) uniform usamplerBuffer host_hits; // HitRecord
layout(std430, set = 0, binding = HOST_RAYS_BINDING + 2) writeonly buffer HostQueue { uint host_queue[]; };

// Queues a closest-hit query of the whole ray (as trace(origin, direction, infinity, false)),
// or marks the slot empty.
void host_ray_write(uint slot, bool live, vec3 origin, vec3 direction)
{
    if (live)
        host_rays[slot] = Ray(vec4(origin, 0.0), vec4(direction, uintBitsToFloat(0x7f800000u)));
    host_queue[slot] = live ? 1u : 0u;
}

#ifdef PF_SCENE_TRACE_GLSL
BihHit host_hit(uint slot)
{
    int at = int(4u * slot);
    return BihHit(uintBitsToFloat(texelFetch(host_hits, at).x), texelFetch(host_hits, at + 1).x,
                  uintBitsToFloat(texelFetch(host_hits, at + 2).x),
                  uintBitsToFloat(texelFetch(host_hits, at + 3).x));
}
#endif

// The image's pixel of this invocation, in the band push.row_first on.
uvec2 band_pixel()
{
    return uvec2(gl_GlobalInvocationID.x, gl_GlobalInvocationID.y + push.row_first);
}

// A pixel's slot in its band's camera rays.
uint camera_slot(uint pixel_index)
{
    return pixel_index - push.row_first * params.width;
}

#endif
