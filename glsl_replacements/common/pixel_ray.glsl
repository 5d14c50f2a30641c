// requires: camera_declarations
// A pixel's ray straight from the projection's entries, with no inverse projection of a
// depth value (which loses digits near a box's edges): in view space it starts at the eye
// (perspective) or on the eye plane (parallel) and runs along view -z scaled so that its
// parameter is the view depth: the near plane is at t = near, and a point at t projects
// back onto this pixel. Needs camera_declarations (cm_projection). A stereo eye's
// projection is sheared and moved sideways (VTK's per-eye offset): its eye is where the
// projection's x and y vanish on the eye plane, not the view's origin.
void cm_pixelRay(vec2 ndc, out vec3 originView, out vec3 directionView)
{
  mat4 p = cm_projection;
  if (p[3][3] == 0.0)   // perspective: the eye, through the pixel at view depth 1
  {
    originView = vec3(-p[3][0] / p[0][0], -p[3][1] / p[1][1], 0.0);
    directionView = vec3((ndc.x + p[2][0]) / p[0][0], (ndc.y + p[2][1]) / p[1][1], -1.0);
  }
  else                  // parallel: the pixel's point on the eye plane, straight ahead
  {                     // (slanted by a stereo eye's shear)
    originView = vec3((ndc.x - p[3][0]) / p[0][0], (ndc.y - p[3][1]) / p[1][1], 0.0);
    directionView = vec3(p[2][0] / p[0][0], p[2][1] / p[1][1], -1.0);
  }
}

// This fragment's ray in view space and in the technique's own space (cm_textureFromView,
// made in double precision, camera-relative), from the fragment's window position.
void cm_fragmentRay(out vec3 originView, out vec3 directionView, out vec3 origin,
                    out vec3 direction)
{
  vec2 pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  cm_pixelRay(pixel * 2.0 - 1.0, originView, directionView);
  origin = (cm_textureFromView * vec4(originView, 1.0)).xyz;
  direction = mat3(cm_textureFromView) * directionView;
}
