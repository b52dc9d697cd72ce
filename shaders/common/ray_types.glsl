// The ray and hit records of the ray-casting kernels (std430; C mirrors
// pf_ray and pf_hit in core/bih/pf_bih.h, 32 and 16 bytes).
#ifndef RAY_TYPES_GLSL
#define RAY_TYPES_GLSL

struct Ray {
    vec4 origin_tmin;    // xyz origin, w = tmin
    vec4 direction_tmax; // xyz direction, w = tmax
};

struct HitRecord {
    float t;             // -1 on a miss
    uint triangle;       // frame triangle index, 0xFFFFFFFF on a miss
    float u, v;
};

#endif
