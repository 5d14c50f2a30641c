// Screen rays of box actors and passes: the camera's uniforms (made in double precision on
// the CPU, camera-relative) and the view-space point under a window position. The box's back
// faces are drawn; each fragment reconstructs its eye ray from the window position, so the
// camera inside the box and a near plane cutting it need no special case.
uniform vec4 cm_viewport;             // origin and size of the renderer, in pixels
uniform mat4 cm_inverseProjection;    // normalised device coordinates to view
uniform mat4 cm_projection;           // view to clip
uniform mat4 cm_textureFromView;      // view to the technique's own (texture or index) space

vec3 cm_viewPoint(vec2 ndc, float windowDepth)
{
  vec4 point = cm_inverseProjection * vec4(ndc, windowDepth * 2.0 - 1.0, 1.0);
  return point.xyz / point.w;
}

// The view depth of a window depth (0: the near plane, 1: the far plane), from the
// projection's entries: what the rasterizer clips against.
float cm_viewDepthOf(float windowDepth)
{
  mat4 p = cm_projection;
  float z = windowDepth * 2.0 - 1.0;
  return p[3][3] == 0.0 ? p[3][2] / (z + p[2][2]) : (p[3][2] - z) / p[2][2];
}
