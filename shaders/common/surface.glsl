// The surface a ray hit, as every kernel that shades or scatters needs it:
// position, face and shading normals turned to the arriving ray's side, and
// the material. One copy, so the preview, reference and photon kernels agree
// on normals (the rule for bad normals below matters for energy and NaNs).
//
// The including shader includes scene_geometry.glsl (the triangles, their
// normals and materials) and bih_traverse.glsl (BihHit) first.
#ifndef PF_SURFACE_GLSL
#define PF_SURFACE_GLSL

#include "materials.glsl" // all_finite
#include "scene_types.glsl"

struct Surface {
    vec3 position;
    vec3 face_normal;      // unit, from the winding (front side = counter-clockwise)
    bool front;            // the ray arrived at the front face
    vec3 geometric_normal; // face_normal turned to the arriving ray's side
    vec3 shading_normal;   // interpolated vertex normal, on the same side
    bool valid;            // false: the interpolated normal is not finite (the
                           // caller drops the sample or photon and counts it)
    Material material;     // with its textures and COLOR_0 at the hit
    vec3 pick_emission;    // the untextured emission the light-pick table weighs (MIS pdfs)
};

// The surface at hit (a hit, not a miss) of the ray origin + t direction. A
// zero interpolated normal falls back to the face's; a non-finite one makes
// the surface invalid rather than being silently repaired. cone_width: the
// ray cone's width at the hit, which picks the textures' mip level (0: the
// finest level).
Surface surface_at_cone(BihHit hit, vec3 origin, vec3 direction, float cone_width)
{
    Surface s;
    uint first = 3u * hit.triangle;
    vec3 v0 = scene_vertex(first);
    vec3 v1 = scene_vertex(first + 1u);
    vec3 v2 = scene_vertex(first + 2u);
    s.material = scene_material(scene_triangle_material(hit.triangle));
    s.pick_emission = s.material.emission;
    s.face_normal = normalize(cross(v1 - v0, v2 - v0));
    s.front = dot(s.face_normal, direction) < 0.0;
    s.material = scene_material_textured(s.material, hit.triangle, hit.u, hit.v, cone_width,
                                         abs(dot(s.face_normal, direction)), v0, v1, v2);
    s.geometric_normal = s.front ? s.face_normal : -s.face_normal;
    vec3 interpolated = (1.0 - hit.u - hit.v) * scene_normal(first) +
                        hit.u * scene_normal(first + 1u) + hit.v * scene_normal(first + 2u);
    // The mesh's normal on its own side (a zero one: the face's), then its normal map.
    vec3 mesh_normal = dot(interpolated, interpolated) == 0.0 ? s.face_normal
                                                              : normalize(interpolated);
    s.shading_normal = scene_normal_mapped(s.material, hit.triangle, hit.u, hit.v, mesh_normal,
                                           cone_width, abs(dot(s.face_normal, direction)), v0, v1,
                                           v2);
    s.valid = all_finite(s.shading_normal) && all_finite(s.face_normal);
    if (dot(s.shading_normal, s.geometric_normal) < 0.0)
        s.shading_normal = -s.shading_normal;
    s.material = scene_coat_normal(s.material, hit.triangle, hit.u, hit.v, s.geometric_normal);
    s.position = origin + hit.t * direction;
    return s;
}

Surface surface_at(BihHit hit, vec3 origin, vec3 direction)
{
    return surface_at_cone(hit, origin, direction, 0.0);
}

#endif
