// Pinhole camera rays (pf_camera + pf_camera_image_plane): pixel (x, y) with
// row 0 at the top maps onto the image plane at distance 1 whose half extents
// are tan_half_x, tan_half_y.
#ifndef PF_CAMERA_GLSL
#define PF_CAMERA_GLSL

// film: position in pixels (0..width, 0..height); returns a unit direction.
vec3 camera_ray_direction(vec3 forward, vec3 right, vec3 up, float tan_half_x, float tan_half_y,
                          vec2 film, vec2 size)
{
    vec2 ndc = vec2(2.0 * film.x / size.x - 1.0, 1.0 - 2.0 * film.y / size.y);
    return normalize(forward + (ndc.x * tan_half_x) * right + (ndc.y * tan_half_y) * up);
}

// The angle one pixel spans at the image's centre: the spread of a camera ray's
// cone (ray cones, Akenine-Möller et al. 2019). Its width at distance d along the
// camera's path (through mirrors and glass too, whose curvature it ignores) is
// d times this: surface_at_cone's cone_width, which picks the textures' mip level.
float camera_cone_spread(float tan_half_y, uint height)
{
    return 2.0 * tan_half_y / float(height);
}

#endif
