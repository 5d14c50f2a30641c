// requires: camera_declarations, slab, pixel_ray
// A screen pixel's ray through a box, shared by every screen-space technique: cm_pixelRay's
// ray (straight from the projection, parameter = view depth), cut to the box by the slab
// test in the space cm_textureFromView maps to, to the near and far planes, to the opaque
// scene's depth, and (with CM_CLIP_PLANES) to what the clipping planes keep. The box is
// [lo, hi]; sceneDepth is a window depth (1: nothing opaque).
bool cm_screenRayBox(vec2 ndc, float sceneDepth, vec3 lo, vec3 hi,
                     out vec3 entry, out vec3 exit, out vec3 entryView, out vec3 exitView)
{
  vec3 originView, directionView;
  cm_pixelRay(ndc, originView, directionView);
  vec3 origin = (cm_textureFromView * vec4(originView, 1.0)).xyz;
  vec3 direction = mat3(cm_textureFromView) * directionView;
  vec2 inBox = cm_slab(origin, direction, lo, hi);
#ifdef CM_CLIP_PLANES
  inBox = cm_clipInterval(origin, direction, inBox);
#endif
  float t0 = max(cm_viewDepthOf(0.0), inBox.x);
  float t1 = min(inBox.y, min(cm_viewDepthOf(1.0), cm_viewDepthOf(sceneDepth)));
  float t = max(t0, t1);
  entry = origin + t0 * direction;
  exit = origin + t * direction;
  entryView = originView + t0 * directionView;
  exitView = originView + t * directionView;
  return t1 > t0;
}

// The same through a volume's box of texel centres (texture coordinates; needs cm_dims).
bool cm_screenRay(vec2 ndc, float sceneDepth,
                  out vec3 entry, out vec3 exit, out vec3 entryView, out vec3 exitView)
{
  return cm_screenRayBox(ndc, sceneDepth, 0.5 / cm_dims, 1.0 - 0.5 / cm_dims,
                         entry, exit, entryView, exitView);
}
