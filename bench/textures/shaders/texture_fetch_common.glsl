// What both texture_fetch kernels share (bench/textures/texture_fetch_bench.c):
// each invocation takes FETCHES samples, each of a texture, a uv and a mip level
// drawn from its own hash, and writes their sum (the host checks that both
// paths agree). push.divergent 1: every lane picks its own texture (a ray's
// hits); 0: one texture per workgroup.
layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint textures;   // how many
    uint edge;       // level 0's width and height (square, a power of two)
    uint levels;
    uint divergent;
} push;

layout(std430, set = 0, binding = 0) buffer Sums { vec4 sums[]; };

const uint FETCHES = 16u;

uint hash(uint x)
{
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    return x ^ (x >> 16);
}

float unit(uint x)
{
    return float(x >> 8) * (1.0 / 16777216.0);
}

vec4 fetch(uint texture_index, vec2 uv, uint level);
void prepare(); // what a workgroup sets up before its fetches

void main()
{
    prepare();
    uint id = gl_GlobalInvocationID.x;
    vec4 sum = vec4(0.0);
    for (uint k = 0u; k < FETCHES; k++) {
        uint h = hash(id * FETCHES + k + 1u);
        uint t = hash(push.divergent != 0u ? h : gl_WorkGroupID.x * FETCHES + k) % push.textures;
        vec2 uv = vec2(unit(hash(h ^ 0x68e31da4u)), unit(hash(h ^ 0xb5297a4du))) * 3.0 - 1.0;
        uint level = hash(h ^ 0x1b56c4e9u) % min(push.levels, 4u);
        sum += fetch(t, uv, level);
    }
    sums[id] = sum;
}
