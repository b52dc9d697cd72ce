// Camera rays (pf_camera + pf_camera_image_plane): pixel (x, y) with row 0 at the top maps
// onto the image plane at distance 1 whose half extents are half_x, half_y (a pinhole), or
// onto the view's plane of those half extents in world units, whose rays are parallel
// (orthographic: FrameParams' camera_up.w).
#ifndef PF_CAMERA_GLSL
#define PF_CAMERA_GLSL

// A camera ray: where it starts, and its unit direction.
struct CameraRay {
    vec3 origin;
    vec3 direction;
};

// film: position in pixels (0..width, 0..height).
CameraRay camera_ray(vec3 position, vec3 forward, vec3 right, vec3 up, float half_x,
                     float half_y, bool orthographic, vec2 film, vec2 size)
{
    vec2 ndc = vec2(2.0 * film.x / size.x - 1.0, 1.0 - 2.0 * film.y / size.y);
    if (orthographic)
        return CameraRay(position + (ndc.x * half_x) * right + (ndc.y * half_y) * up, forward);
    return CameraRay(position,
                     normalize(forward + (ndc.x * half_x) * right + (ndc.y * half_y) * up));
}

// A camera ray's cone (ray cones, Akenine-Möller et al. 2019): its width where it leaves the
// camera, and its spread, the angle one pixel spans at the image's centre. Its width at
// distance d along the camera's path (through mirrors and glass too, whose curvature it
// ignores) is x + d y: surface_at_cone's cone_width, which picks the textures' mip level. A
// pinhole's cone starts at a point; parallel rays keep a pixel's width and do not spread.
vec2 camera_cone(float half_y, uint height, bool orthographic)
{
    float pixel = 2.0 * half_y / float(height);
    return orthographic ? vec2(pixel, 0.0) : vec2(0.0, pixel);
}

#endif
