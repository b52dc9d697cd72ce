// Diffuse irradiance from the cascaded light propagation volumes
// (core/lpv/pf_lpv.h): the `fast` preset's indirect light.
//
// The including shader declares, as samplerBuffers (RGBA32F texels: llvmpipe
// fetches a texel for all lanes at once, a storage buffer lane by lane):
//   lpv_cell_texels      every cascade's accumulated intensity SH, three texels
//                        (R, G, B) per cell, cascade k from k × size³ cells on
//   lpv_far_texels       the same layout: each cascade's far field, its accumulation
//                        minus the accumulation after its snapshot iterations
//                        (pf_lpv_cascade.snapshot_iterations)
//   lpv_cascade_texels   one per cascade: origin of cell (0, 0, 0) in xyz, cell size in w
//   lpv_geometry_texels  the geometry volumes (lpv_geometry.glsl)
// and includes lpv_sh.glsl and lpv_geometry.glsl first.
//
// At a surface point x with normal n, cascade k is read at x + n × s_k / 2
// (half a cell out of the surface, where the injection put the surface's
// own light: light bleeding dampening along the normal), trilinearly over
// the cell centres around it that no surface separates from the cell
// holding the point (a corner across a face that the geometry volume
// blocks by half or more, from either side, is left out and the weights
// renormalised: a floor next to a thin wall does not average in the
// other room's cells), and
// the irradiance is E = max(0, Σ c · lobe(−n)) / s² per channel: the cell's
// intensity flowing into the surface, over the cell's cross-section. The
// finest cascade whose interior holds the point is used, blended into the
// next coarser over LPV_BLEND_CELLS cells near its border. A cascade's light
// travels only its iterations × its cell size, so each coarser cascade j
// that holds the point adds its far field, (accumulated − snapshot) · lobe,
// the light its propagation brought from beyond the finer cascades' reach:
// with the blend weights w_k of the cascades used,
//     E = Σ_k w_k E_k + Σ_j F_j Σ_{k<j} w_k. With damping, E
// is scaled by min(1, 2 E_out / E), E_out read one cell further out: light
// that reaches the surface from its own side is still there a cell out,
// light present only in the surface's own cell came through it (Kaplanyan
// & Dachsbacher 2010's directional-derivative test, as a finite difference).
#ifndef PF_LPV_LOOKUP_GLSL
#define PF_LPV_LOOKUP_GLSL

const float LPV_BLEND_CELLS = 2.0;

// A corner this far blocked from the point's own cell is not interpolated.
const float LPV_VISIBLE_BLOCKING = 0.5;

// 1 when the face between cell c and c + s·e_k lets light through both ways.
bool lpv_face_open(ivec3 c, int k, int s, uint base, uint size)
{
    // lpv_face_geometry(d, k, s') names the face between d and d − s'·e_k.
    vec4 gv = lpv_face_geometry(c, k, -s, base, size);
    vec3 axis = vec3(0.0);
    axis[k] = 1.0;
    return max(sh_blocking(gv, axis), sh_blocking(gv, -axis)) < LPV_VISIBLE_BLOCKING;
}

// Trilinear weights of the 8 cell centres around g (cell centres at
// integers) with the corners that a surface separates from g's own cell
// dropped and the rest renormalised; base: the lowest corner.
void lpv_visible_weights(uint k, uint size, vec3 g, out ivec3 base, out float weights[8])
{
    vec3 lower = floor(g);
    vec3 f = g - lower;
    base = ivec3(lower);
    ivec3 own = ivec3(floor(g + 0.5));
    uint gv_base = k * size * size * size;
    bool open_axis[3];
    for (int axis = 0; axis < 3; axis++) {
        // The neighbour of the own cell along this axis that the corners use.
        int s = base[axis] == own[axis] ? 1 : -1;
        open_axis[axis] = lpv_face_open(own, axis, s, gv_base, size);
    }
    float total = 0.0;
    for (int corner = 0; corner < 8; corner++) {
        ivec3 o = ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        ivec3 c = base + o;
        bool visible = true;
        for (int axis = 0; axis < 3; axis++) {
            if (c[axis] != own[axis] && !open_axis[axis])
                visible = false;
        }
        vec3 w3 = mix(1.0 - f, f, vec3(o));
        weights[corner] = visible ? w3.x * w3.y * w3.z : 0.0;
        total += weights[corner];
    }
    for (int corner = 0; corner < 8; corner++)
        weights[corner] = total > 0.0 ? weights[corner] / total : 0.0;
}

uint lpv_corner_index(uint k, uint size, ivec3 base, int corner)
{
    ivec3 o = ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    ivec3 c = clamp(base + o, ivec3(0), ivec3(int(size) - 1));
    return 3u * (k * size * size * size + (uint(c.z) * size + uint(c.y)) * size + uint(c.x));
}

// Interpolated SH of cascade k at g, dotted with lobe; far: the far field's.
vec3 lpv_dot_interpolated(uint k, uint size, vec3 g, vec4 lobe, bool far)
{
    ivec3 base;
    float weights[8];
    lpv_visible_weights(k, size, g, base, weights);
    vec3 sum = vec3(0.0);
    for (int corner = 0; corner < 8; corner++) {
        if (weights[corner] == 0.0)
            continue;
        uint i = lpv_corner_index(k, size, base, corner);
        vec4 r, gg, b;
        if (far) {
            r = texelFetch(lpv_far_texels, int(i));
            gg = texelFetch(lpv_far_texels, int(i + 1u));
            b = texelFetch(lpv_far_texels, int(i + 2u));
        } else {
            r = texelFetch(lpv_cell_texels, int(i));
            gg = texelFetch(lpv_cell_texels, int(i + 1u));
            b = texelFetch(lpv_cell_texels, int(i + 2u));
        }
        sum += weights[corner] * vec3(dot(r, lobe), dot(gg, lobe), dot(b, lobe));
    }
    return sum;
}

// Most cascades a layout has (pf_lpv.h's PF_LPV_MAX_CASCADES).
const uint LPV_MAX_CASCADES = 8u;

// Cascade k's cell coordinates (cell centres at integers) of the point half a cell out of
// the surface, and its cell size.
vec3 lpv_cascade_point(uint k, vec3 position, vec3 normal, out float s)
{
    vec4 cascade = texelFetch(lpv_cascade_texels, int(k));
    s = cascade.w;
    return (position + 0.5 * s * normal - cascade.xyz) / s - 0.5;
}

// Irradiance (W/m², RGB) at position on a surface of unit normal; covered
// says whether some cascade held the point (false: 0 is returned).
//
// First the lookups the point needs, each with the weight its value gets: the far
// fields of the coarser cascades and the near fields (with the damping's second read)
// of the cascades that get weight. Then a loop over each list, one lookup per
// iteration, each list reading one volume. Written as one loop over the cascades with
// the three lookups each behind an `if`, llvmpipe ran all of them for every cascade
// and lane (it runs an `if` masked, but a loop only until its last lane leaves): 12
// lookups for 4 cascades where a point needs about 5 (bench/RESULTS.md).
vec3 lpv_irradiance(vec3 position, vec3 normal, uint cascade_count, uint size, bool damping,
                    out bool covered)
{
    vec4 lobe = sh_cosine_lobe(-normal);
    uint far_cascade[LPV_MAX_CASCADES], near_cascade[LPV_MAX_CASCADES];
    float far_weight[LPV_MAX_CASCADES], near_weight[LPV_MAX_CASCADES];
    uint fars = 0u, nears = 0u;
    float remaining = 1.0; // weight not yet given to a cascade's near field
    covered = false;
    for (uint k = 0u; k < min(cascade_count, LPV_MAX_CASCADES); k++) {
        float s;
        vec3 g = lpv_cascade_point(k, position, normal, s);
        vec3 to_edge = min(g, vec3(float(size) - 1.0) - g);
        float edge = min(to_edge.x, min(to_edge.y, to_edge.z));
        if (edge < 0.0)
            continue;
        float used = 1.0 - remaining; // Σ of the finer cascades' weights
        if (covered && used > 0.0) {
            far_cascade[fars] = k;
            far_weight[fars++] = used;
        }
        covered = true;
        float weight = k + 1u == cascade_count ? 1.0 : clamp(edge / LPV_BLEND_CELLS, 0.0, 1.0);
        if (weight <= 0.0 || remaining <= 0.0)
            continue;
        near_cascade[nears] = k;
        near_weight[nears++] = remaining * weight;
        remaining *= 1.0 - weight;
    }
    vec3 irradiance = vec3(0.0);
    for (uint i = 0u; i < nears; i++) {
        uint k = near_cascade[i];
        float s;
        vec3 g = lpv_cascade_point(k, position, normal, s);
        vec3 e = max(lpv_dot_interpolated(k, size, g, lobe, false), vec3(0.0)) / (s * s);
        if (damping) {
            // Light present only in the surface's own cell came through it.
            vec3 outside =
                max(lpv_dot_interpolated(k, size, g + normal, lobe, false), vec3(0.0)) / (s * s);
            float inner = dot(e, vec3(0.2126, 0.7152, 0.0722));
            float outer = dot(outside, vec3(0.2126, 0.7152, 0.0722));
            if (inner > 0.0)
                e *= min(1.0, 2.0 * outer / inner);
        }
        irradiance += near_weight[i] * e;
    }
    for (uint i = 0u; i < fars; i++) {
        uint k = far_cascade[i];
        float s;
        vec3 g = lpv_cascade_point(k, position, normal, s);
        irradiance +=
            far_weight[i] * max(lpv_dot_interpolated(k, size, g, lobe, true), vec3(0.0)) / (s * s);
    }
    return irradiance;
}

#endif
