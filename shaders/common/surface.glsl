// The surface a ray hit, as every kernel that shades or scatters needs it:
// position, face and shading normals turned to the arriving ray's side, and
// the material. One copy, so the preview, reference and photon kernels agree
// on normals (the rule for bad normals below matters for energy and NaNs).
//
// The including shader declares, before including this file:
//   buffer ... { vec4 triangle_vertices[]; };  // 3 per triangle
//   buffer ... { vec4 triangle_normals[]; };   // 3 per triangle (shading normals)
//   buffer ... { uint triangle_material[]; };
//   buffer ... { Material materials[]; };
// and includes bih_traverse.glsl (BihHit).
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
    vec3 v0 = triangle_vertices[first].xyz;
    vec3 v1 = triangle_vertices[first + 1u].xyz;
    vec3 v2 = triangle_vertices[first + 2u].xyz;
    s.material = materials[triangle_material[hit.triangle]];
    s.face_normal = normalize(cross(v1 - v0, v2 - v0));
    s.front = dot(s.face_normal, direction) < 0.0;
    s.geometric_normal = s.front ? s.face_normal : -s.face_normal;
    vec3 interpolated = (1.0 - hit.u - hit.v) * triangle_normals[first].xyz +
                        hit.u * triangle_normals[first + 1u].xyz +
                        hit.v * triangle_normals[first + 2u].xyz;
    s.shading_normal = dot(interpolated, interpolated) == 0.0 ? s.geometric_normal
                                                              : normalize(interpolated);
    s.valid = all_finite(s.shading_normal) && all_finite(s.face_normal);
    if (dot(s.shading_normal, s.geometric_normal) < 0.0)
        s.shading_normal = -s.shading_normal;
    s.position = origin + hit.t * direction;
    return s;
}

#endif
