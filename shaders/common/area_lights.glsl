// Emissive triangles as area lights (their front face, or both faces of a
// double-sided material: material_emits), shared by every
// integrator: picked by power through the alias table built by
// pf_emissive_table_build, a point uniform on the picked triangle.
//
// These functions read the frame's arrays; the including shader includes
// scene_geometry.glsl (the triangles and materials) and declares, before
// including this file:
//   buffer ... { EmissiveEntry emissive[]; };  // the alias table
#ifndef PF_AREA_LIGHTS_GLSL
#define PF_AREA_LIGHTS_GLSL

#include "lights.glsl"

// Table entry for xi in [0,1)²: column xi.x, kept with its threshold
// (xi.y) or replaced by its alias (Vose 1991). Requires count > 0.
uint emissive_pick(vec2 xi, uint count)
{
    uint column = min(uint(xi.x * float(count)), count - 1u);
    return xi.y < emissive[column].alias_threshold ? column : emissive[column].alias;
}

// Area density (1/m²) with which emissive_sample picks a point on a triangle
// of emitted radiance `emission`: (area·luminance / weight_total) for the
// triangle times 1/area for the point. Used by MIS when a BSDF ray hits an
// emitter, and by emissive_sample itself so the two always agree.
float emissive_pdf_area(vec3 emission, float weight_total)
{
    return weight_total > 0.0 ? light_luminance(emission) / weight_total : 0.0;
}

// A point sampled on an emissive triangle as seen from a receiver.
struct AreaLightSample {
    vec3 to_light;       // unit, receiver to the point
    float distance;
    vec3 radiance;       // emitted towards the receiver (0 when it sees the back face)
    float pdf_solid_angle; // density of to_light; 0 when the sample is unusable
};

// Picks an emissive triangle by power and a uniform point on it (pbrt-v4
// SampleUniformTriangle, square-root form) from xi in [0,1)⁴.
AreaLightSample emissive_sample(vec3 position, vec4 xi, uint count, float weight_total)
{
    AreaLightSample s = AreaLightSample(vec3(0.0, 0.0, 1.0), 0.0, vec3(0.0), 0.0);
    uint triangle = emissive[emissive_pick(xi.xy, count)].triangle;
    uint first = 3u * triangle;
    vec3 a = scene_vertex(first);
    vec3 b = scene_vertex(first + 1u);
    vec3 c = scene_vertex(first + 2u);
    vec2 barycentrics;
    vec3 point = triangle_uniform_point(a, b, c, xi.zw, barycentrics);
    vec3 light_normal = normalize(cross(b - a, c - a));
    vec3 offset = point - position;
    float distance2 = dot(offset, offset);
    if (!(distance2 > 0.0))
        return s;
    s.distance = sqrt(distance2);
    s.to_light = offset / s.distance;
    Material material = scene_material(scene_triangle_material(triangle));
    float cos_light = -dot(light_normal, s.to_light);
    if ((material.flags & MATERIAL_DOUBLE_SIDED) != 0u)
        cos_light = abs(cos_light); // the receiver sees the back face, which emits too
    if (!(cos_light > 0.0))
        return s;
    // The pick pdf weighs the untextured emission (the table's); the radiance is the
    // emissive texture's at the point.
    s.pdf_solid_angle = emissive_pdf_area(material.emission, weight_total) * distance2 / cos_light;
    s.radiance = material.emission;
    if (material.emissive_texture != NO_TEXTURE)
        s.radiance = scene_material_textured(material, triangle, barycentrics.x,
                                             barycentrics.y, 0.0, 1.0, a, b, c).emission;
    return s;
}

#endif
