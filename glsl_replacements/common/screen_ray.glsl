// A screen pixel's ray through a box, shared by every screen-space technique. The ray runs
// from the near plane (f = 0) to a given window depth (f = 1: the box's back face, or the far
// plane); view z is linear in f for perspective and parallel projections alike. The box is
// [lo, hi] in the space cm_textureFromView maps to, less what clipping planes cut (with
// CM_CLIP_PLANES). Needs camera_declarations, cm_slab (and clip_planes).
bool cm_screenRayBox(vec2 ndc, float backDepth, float sceneDepth, vec3 lo, vec3 hi,
                     out vec3 entry, out vec3 exit, out vec3 entryView, out vec3 exitView)
{
  vec3 nearView = cm_viewPoint(ndc, 0.0);
  vec3 backView = cm_viewPoint(ndc, backDepth);
  vec3 sceneView = cm_viewPoint(ndc, sceneDepth);
  vec3 a = (cm_textureFromView * vec4(nearView, 1.0)).xyz;
  vec3 b = (cm_textureFromView * vec4(backView, 1.0)).xyz;
  vec2 inBox = cm_slab(a, b - a, lo, hi);
#ifdef CM_CLIP_PLANES
  inBox = cm_clipInterval(a, b - a, inBox);
#endif
  float f0 = max(0.0, inBox.x);
  float f1 = min(1.0, inBox.y);
  float dz = backView.z - nearView.z;
  if (abs(dz) > 0.0)
  {
    f1 = min(f1, (sceneView.z - nearView.z) / dz);
  }
  entry = mix(a, b, f0);
  exit = mix(a, b, max(f0, f1));
  entryView = mix(nearView, backView, f0);
  exitView = mix(nearView, backView, max(f0, f1));
  return f1 > f0;
}

// The same through a volume's box of texel centres (texture coordinates; needs cm_dims).
bool cm_screenRay(vec2 ndc, float backDepth, float sceneDepth,
                  out vec3 entry, out vec3 exit, out vec3 entryView, out vec3 exitView)
{
  return cm_screenRayBox(ndc, backDepth, sceneDepth, 0.5 / cm_dims, 1.0 - 0.5 / cm_dims,
                         entry, exit, entryView, exitView);
}
