#version 460
// The `deform` stage's per-vertex half on the device (issue 39): morph targets,
// then linear blend skinning, of one mesh node's vertices, operation for
// operation as pf_deform_vertices_host (core/scene/deform.c), which
// pf_scene.h's pf_deform_node describes. Per vertex v:
//   p = rest position + Σ_t w_t·Δp[v][t]   (normals and tangent deltas alike)
//   M = Σ_i joint_weight[v][i]·matrices[joint[v][i]]  (identity where they sum
//       to 0; matrices[0] for every vertex when the node has no influences)
//   position = M·p, normal = cof(M)·n, matrix = M (3×4, column-major).
// The host then gathers the triangles' corners from these, as after its own.
// The inputs are read through texel views (one word a texel): llvmpipe loads a
// storage buffer lane by lane (bih_traverse.glsl).

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint vertex_count;
    uint target_count;
    uint influences; // 0, 4 or 8
    uint deltas;     // bit 0: position deltas, 1: normal deltas, 2: tangent deltas
} push;

layout(set = 0, binding = 0) uniform usamplerBuffer rest_positions;   // 3 floats a vertex
layout(set = 0, binding = 1) uniform usamplerBuffer rest_normals;
layout(set = 0, binding = 2) uniform usamplerBuffer target_positions; // [v][t][3]
layout(set = 0, binding = 3) uniform usamplerBuffer target_normals;
layout(set = 0, binding = 4) uniform usamplerBuffer target_tangents;
layout(set = 0, binding = 5) uniform usamplerBuffer joints;           // influences a vertex
layout(set = 0, binding = 6) uniform usamplerBuffer joint_weights;
layout(set = 0, binding = 7) uniform usamplerBuffer weights;          // target_count
layout(set = 0, binding = 8) uniform usamplerBuffer matrices;         // 12 floats a matrix
layout(std430, set = 0, binding = 9) writeonly buffer OutPosition { float out_position[]; };
layout(std430, set = 0, binding = 10) writeonly buffer OutNormal { float out_normal[]; };
layout(std430, set = 0, binding = 11) writeonly buffer OutTangent { float out_tangent[]; };
layout(std430, set = 0, binding = 12) writeonly buffer OutMatrix { float out_matrix[]; };

float word(usamplerBuffer texels, uint index)
{
    return uintBitsToFloat(texelFetch(texels, int(index)).x);
}

void main()
{
    uint v = gl_GlobalInvocationID.x;
    if (v >= push.vertex_count)
        return;
    float p[3], n[3], t[3];
    for (uint k = 0u; k < 3u; k++) {
        p[k] = word(rest_positions, 3u * v + k);
        n[k] = word(rest_normals, 3u * v + k);
        t[k] = 0.0;
    }
    for (uint target = 0u; target < push.target_count; target++) {
        float w = word(weights, target);
        if (w == 0.0)
            continue;
        uint at = (v * push.target_count + target) * 3u;
        for (uint k = 0u; k < 3u; k++) {
            if ((push.deltas & 1u) != 0u)
                p[k] += w * word(target_positions, at + k);
            if ((push.deltas & 2u) != 0u)
                n[k] += w * word(target_normals, at + k);
            if ((push.deltas & 4u) != 0u)
                t[k] += w * word(target_tangents, at + k);
        }
    }

    float m[12];
    if (push.influences == 0u) {
        for (uint k = 0u; k < 12u; k++)
            m[k] = word(matrices, k);
    } else {
        float total = 0.0;
        for (uint k = 0u; k < 12u; k++)
            m[k] = 0.0;
        for (uint i = 0u; i < push.influences; i++) {
            float w = word(joint_weights, v * push.influences + i);
            if (w == 0.0)
                continue;
            uint joint = texelFetch(joints, int(v * push.influences + i)).x;
            for (uint k = 0u; k < 12u; k++)
                m[k] += w * word(matrices, 12u * joint + k);
            total += w;
        }
        if (!(total > 0.0))
            m = float[12](1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    }

    // M·p and cof(M)·n in deform.c's order (apply_point, cofactor_apply).
    float a = m[0], b = m[3], c = m[6];
    float d = m[1], e = m[4], f = m[7];
    float g = m[2], h = m[5], i = m[8];
    float c00 = e * i - f * h, c01 = -(d * i - f * g), c02 = d * h - e * g;
    float c10 = -(b * i - c * h), c11 = a * i - c * g, c12 = -(a * h - b * g);
    float c20 = b * f - c * e, c21 = -(a * f - c * d), c22 = a * e - b * d;
    for (uint r = 0u; r < 3u; r++)
        out_position[3u * v + r] = m[r] * p[0] + m[3u + r] * p[1] + m[6u + r] * p[2] + m[9u + r];
    out_normal[3u * v + 0u] = c00 * n[0] + c01 * n[1] + c02 * n[2];
    out_normal[3u * v + 1u] = c10 * n[0] + c11 * n[1] + c12 * n[2];
    out_normal[3u * v + 2u] = c20 * n[0] + c21 * n[1] + c22 * n[2];
    if ((push.deltas & 4u) != 0u)
        for (uint k = 0u; k < 3u; k++)
            out_tangent[3u * v + k] = t[k];
    for (uint k = 0u; k < 12u; k++)
        out_matrix[12u * v + k] = m[k];
}
