#version 460
#extension GL_GOOGLE_include_directive : require
// GPU BIH build, pass 1: a 30-bit Morton code (10 bits per axis, x highest)
// of each triangle's bounding-box centre — the centre the CPU build sorts by —
// normalised by the scene box, and the identity triangle index as the value.
// The radix sort is stable, so equal codes stay in index order: the index is
// the tie-break of the 62-bit key (code, index).

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    vec4 scene_min;   // xyz
    vec4 scale;       // xyz: 1024 / extent, 0 on a flat axis (all cells 0)
    uint count;
} push;

layout(std430, set = 0, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Values { uint values[]; };

// Spreads the low 10 bits of v two bits apart (bit k goes to bit 3k).
uint expand_bits(uint v)
{
    v = (v | (v << 16)) & 0x030000FFu;
    v = (v | (v << 8)) & 0x0300F00Fu;
    v = (v | (v << 4)) & 0x030C30C3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count)
        return;
    vec3 a = vertices[3 * i].xyz, b = vertices[3 * i + 1].xyz, c = vertices[3 * i + 2].xyz;
    vec3 centre = 0.5 * (min(min(a, b), c) + max(max(a, b), c));
    uvec3 cell = uvec3(clamp((centre - push.scene_min.xyz) * push.scale.xyz, vec3(0.0), vec3(1023.0)));
    keys[i] = (expand_bits(cell.x) << 2) | (expand_bits(cell.y) << 1) | expand_bits(cell.z);
    values[i] = i;
}
