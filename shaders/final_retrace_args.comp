#version 460
// The workgroup counts of final's retrace (core/render/frame_final.c): the
// gather's rays whose deferred requests found fallback_requests full are
// retraced with their estimates in place (final_gather_estimate.comp) before
// the resolve. Whether any did is known on the device alone, so this invocation
// writes the retrace's indirect dispatch: the image's groups where the requests
// overflowed the capacity, none where they did not. The sample is then one
// submission, not two with the counters read back in between.

layout(local_size_x = 1) in;

layout(push_constant) uniform Push {
    uint groups_x;  // the image's workgroups, as the gather's dispatches
    uint groups_y;
    uint capacity;  // requests fallback_requests holds (the gather's fallback_capacity)
} push;

// final_shared.glsl's Counters, read-only: the gather's requests at word 6.
layout(std430, set = 0, binding = 0) readonly buffer Counters {
    uint discarded_samples;
    uint traversal_failures;
    uint rays_low;
    uint rays_high;
    uint loop_truncated;
    uint gather_dropped;
    uint fallback_requests;
} counters;
layout(std430, set = 0, binding = 1) writeonly buffer Groups { uvec4 groups; };

void main()
{
    bool overflow = counters.fallback_requests > push.capacity;
    groups = overflow ? uvec4(push.groups_x, push.groups_y, 1u, 0u) : uvec4(0u);
}
