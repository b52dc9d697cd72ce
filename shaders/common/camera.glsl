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

// The angle one pixel spans at the image's centre: the spread of a camera ray's
// cone (ray cones, Akenine-Möller et al. 2019). Its width at distance d along the
// camera's path (through mirrors and glass too, whose curvature it ignores) is
// d times this: surface_at_cone's cone_width, which picks the textures' mip level.
// Parallel rays spread by nothing (their cone keeps a pixel's width, which this model of a
// cone from a point leaves out: the finest texture level, sharp and noisier).
float camera_cone_spread(float tan_half_y, uint height, bool orthographic)
{
    return orthographic ? 0.0 : 2.0 * tan_half_y / float(height);
}

#endif
