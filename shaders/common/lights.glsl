// Lights shared by every integrator: punctual lights (pf_light_kind) and the
// luminance that lights are picked by. Emissive triangles as area lights:
// area_lights.glsl.
#ifndef PF_LIGHTS_GLSL
#define PF_LIGHTS_GLSL

#include "scene_types.glsl"

// Direction to the light, its distance (a huge value for directional lights)
// and the irradiance it delivers at position on a surface facing it
// (the cosine at the receiver is the caller's), without occlusion.
struct LightSample {
    vec3 to_light;
    float distance;
    vec3 irradiance;
};

const float DIRECTIONAL_LIGHT_DISTANCE = 1e30;

// glTF KHR_lights_punctual recommended range window: (1 - (d/range)^4)^2, clamped.
float light_range_window(float distance, float range)
{
    if (range <= 0.0)
        return 1.0;
    float ratio = distance / range;
    float window = clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);
    return window * window;
}

// KHR_lights_punctual's spot falloff, as the spec's reference implementation
// writes it: the cosine mapped linearly from the outer cone (0) to the inner
// cone (1), clamped, then squared. Equal cones (a hard edge) are the limit
// of that ramp: a step at the outer cone (the spec's max(0.001, ...) guard
// keeps a ramp 0.001 wide there instead).
float spot_falloff(float cos_angle, float cos_inner, float cos_outer)
{
    if (cos_inner <= cos_outer)
        return cos_angle >= cos_outer ? 1.0 : 0.0;
    float x = clamp((cos_angle - cos_outer) / (cos_inner - cos_outer), 0.0, 1.0);
    return x * x;
}

// ∫ spot_falloff dω / 2π over the sphere: 1 − cos_inner inside the inner
// cone, plus the squared ramp's (cos_inner − cos_outer)/3 between the cones
// (pf_photon_light_power uses the same integral for the spot's power).
float spot_cone_integral(float cos_inner, float cos_outer)
{
    if (cos_inner <= cos_outer)
        return 1.0 - cos_outer;
    return (1.0 - cos_inner) + (cos_inner - cos_outer) / 3.0;
}

LightSample light_sample(Light light, vec3 position)
{
    LightSample s;
    if (light.kind == LIGHT_DIRECTIONAL) {
        s.to_light = -light.direction;
        s.distance = DIRECTIONAL_LIGHT_DISTANCE;
        s.irradiance = light.intensity;
        return s;
    }
    vec3 offset = light.position - position;
    float distance2 = max(dot(offset, offset), 1e-20);
    s.distance = sqrt(distance2);
    s.to_light = offset / s.distance;
    s.irradiance = light.intensity * (light_range_window(s.distance, light.range) / distance2);
    if (light.kind == LIGHT_SPOT) {
        float cos_angle = dot(light.direction, -s.to_light);
        s.irradiance *= spot_falloff(cos_angle, light.cos_inner_cone, light.cos_outer_cone);
    }
    return s;
}

// Rec. 709 luminance: the power measure lights are picked by (the same
// weights as pf_emissive_table_build's LUMINANCE_R/G/B).
float light_luminance(vec3 radiance)
{
    return dot(radiance, vec3(0.2126, 0.7152, 0.0722));
}

#endif
