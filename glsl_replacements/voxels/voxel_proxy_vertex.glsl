// The vertex's view depth (the pixel ray's parameter, pixel_ray.glsl), before any later
// snippet moves gl_Position: w under perspective, from z under a parallel projection.
cm_proxyDepth = cm_projection[3][3] == 0.0 ? gl_Position.w
                : -(gl_Position.z - cm_projection[3][2]) / cm_projection[2][2];
