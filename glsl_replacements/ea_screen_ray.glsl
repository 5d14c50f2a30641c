// A screen pixel's ray through the volume box, shared by the direct marcher and the
// reduced-resolution pass. The ray runs from the near plane (f = 0) to a given window depth
// (f = 1: the box's back face, or the far plane); view z is linear in f for perspective
// and parallel projections alike. Needs cm_viewPoint, cm_textureFromView and cm_dims.
bool cm_screenRay(vec2 ndc, float backDepth, float sceneDepth,
                  out vec3 entry, out vec3 exit, out vec3 entryView, out vec3 exitView)
{
  vec3 nearView = cm_viewPoint(ndc, 0.0);
  vec3 backView = cm_viewPoint(ndc, backDepth);
  vec3 sceneView = cm_viewPoint(ndc, sceneDepth);
  vec3 a = (cm_textureFromView * vec4(nearView, 1.0)).xyz;
  vec3 b = (cm_textureFromView * vec4(backView, 1.0)).xyz;
  // Slab test against the box of texel centres, without epsilons: an axis the ray does not
  // move along bounds nothing (inside its slab) or everything (outside).
  vec3 lo = 0.5 / cm_dims;
  vec3 hi = 1.0 - 0.5 / cm_dims;
  vec3 d = b - a;
  vec3 moving = step(vec3(1e-30), abs(d));
  vec3 safe = mix(vec3(1.0), d, moving);
  vec3 t0 = (lo - a) / safe;
  vec3 t1 = (hi - a) / safe;
  vec3 inside = step(lo, a) * step(a, hi);
  vec3 enter = mix(mix(vec3(1e30), vec3(-1e30), inside), min(t0, t1), moving);
  vec3 leave = mix(mix(vec3(-1e30), vec3(1e30), inside), max(t0, t1), moving);
  float f0 = max(0.0, max(enter.x, max(enter.y, enter.z)));
  float f1 = min(1.0, min(leave.x, min(leave.y, leave.z)));
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
