// requires: surface_declarations, surface_traverse
// Active cells through their index (traversal 'index'): each fragment of the domain box's
// back faces traverses its pixel's ray from where it enters the domain (or the near plane:
// the camera inside the domain or an active cell) to where it leaves (cm_traverse), and
// stops at the first root. Followed by surface_hit.glsl (one block of main: cm_ names).
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and cell space
  vec2 cm_span;
  if (!cm_domainRay(cm_originView, cm_directionView, cm_origin, cm_direction, cm_span))
  {
    discard;
  }
  float cm_start = cm_span.x;
  vec3 cm_a = cm_origin + cm_direction * cm_start;
  vec3 cm_b = cm_origin + cm_direction * cm_span.y;
  ivec3 cm_hitCell;
  float cm_s = cm_traverse(cm_a, cm_b, cm_hitCell);
  if (cm_s < 0.0)
  {
    discard;
  }
  float cm_depth = mix(cm_start, cm_span.y, cm_s);
  vec3 cm_local = clamp(mix(cm_a, cm_b, cm_s) - vec3(cm_hitCell), 0.0, 1.0);
