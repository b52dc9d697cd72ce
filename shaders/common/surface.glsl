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
    Material material;
};

// The surface at hit (a hit, not a miss) of the ray origin + t direction. A
// zero interpolated normal falls back to the face's; a non-finite one makes
// the surface invalid rather than being silently repaired.
Surface surface_at(BihHit hit, vec3 origin, vec3 direction)
{
    Surface s;
    uint first = 3u * hit.triangle;
    vec3 v0 = scene_vertex(first);
    vec3 v1 = scene_vertex(first + 1u);
    vec3 v2 = scene_vertex(first + 2u);
    s.material = scene_material(scene_triangle_material(hit.triangle));
    s.face_normal = normalize(cross(v1 - v0, v2 - v0));
    s.front = dot(s.face_normal, direction) < 0.0;
    s.geometric_normal = s.front ? s.face_normal : -s.face_normal;
    vec3 interpolated = (1.0 - hit.u - hit.v) * scene_normal(first) +
                        hit.u * scene_normal(first + 1u) + hit.v * scene_normal(first + 2u);
    s.shading_normal = dot(interpolated, interpolated) == 0.0 ? s.geometric_normal
                                                              : normalize(interpolated);
    s.valid = all_finite(s.shading_normal) && all_finite(s.face_normal);
    if (dot(s.shading_normal, s.geometric_normal) < 0.0)
        s.shading_normal = -s.shading_normal;
    s.position = origin + hit.t * direction;
    return s;
}

#endif
