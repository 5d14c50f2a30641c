// requires: camera_declarations, surface_declarations, surface_shade_hit, surface_traverse
// requires: layer_output_declarations
// Translucent surface (surface_layer_declarations says what it draws): each crossing up to
// the opaque depth, found by the active cells' traversal from just past the one before
// (cm_rootPast, or cm_nudge further), composited front to back until the ray is opaque
// or CM_MAX_LAYERS crossings are taken. One block of main, where VTK sets the depth: cm_
// names; the colour is written after VTK's lighting (layer_output.glsl).
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and cell space
  vec2 cm_span;
  if (!cm_domainRay(cm_originView, cm_directionView, cm_origin, cm_direction, cm_span))
  {
    discard;
  }
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  // The opaque depth as a view depth: the ray's parameter is the view depth (pixel_ray).
  float cm_opaque = -cm_viewPoint(cm_pixel * 2.0 - 1.0,
                                  texture(cm_sceneDepth, cm_pixel).r).z;
  float cm_end = min(cm_span.y, cm_opaque);
  float cm_from = cm_span.x;
  // The least step past a root (beyond its bracket, cm_rootPast), in ray units: 1e-4 cell,
  // or 2e-6 of the larger of the distances from the grid's origin and along the ray, in
  // cells: float32 rounding (6e-8 of them, and the cells' polynomials meeting at a face)
  // could otherwise put the restart before the root just found, finding it again (seen: a
  // far camera drawing a translucent ball opaque). Two crossings closer than that are one.
  float cm_cellsPerUnit = max(length(cm_direction), 1e-30);
  float cm_reach = max(length(cm_origin), cm_span.y * cm_cellsPerUnit);   // cells
  float cm_nudge = max(1e-4, 2e-6 * cm_reach) / cm_cellsPerUnit;
  vec4 cm_held = vec4(0.0);
  float cm_first = -1.0;   // the view depth of the first crossing
  for (int cm_layer = 0; cm_layer < CM_MAX_LAYERS && cm_held.a < 0.999 && cm_end > cm_from;
       ++cm_layer)
  {
    vec3 cm_a = cm_origin + cm_direction * cm_from;
    vec3 cm_b = cm_origin + cm_direction * cm_end;
    ivec3 cm_hitCell;
    float cm_s = cm_traverse(cm_a, cm_b, cm_hitCell);
    if (cm_s < 0.0)
    {
      break;
    }
    float cm_past = mix(cm_from, cm_end, cm_rootPast);
    float cm_depth = mix(cm_from, cm_end, cm_s);
    vec3 cm_local = clamp(mix(cm_a, cm_b, cm_s) - vec3(cm_hitCell), 0.0, 1.0);
    vec3 cm_hitView = cm_originView + cm_directionView * cm_depth;
    vec3 cm_color = cm_hitColor(cm_hitCell, cm_local, cm_hitView, cm_directionView);
    cm_held += (1.0 - cm_held.a) * cm_opacity * vec4(clamp(cm_color, 0.0, 1.0), 1.0);
    cm_first = cm_first < 0.0 ? cm_depth : cm_first;
    cm_from = max(cm_past, cm_depth + cm_nudge);
  }
  if (!(cm_held.a > 0.0))
  {
    discard;
  }
  cm_layerColor = vec4(cm_held.rgb / cm_held.a, cm_held.a);
  vec4 cm_clip = cm_projection * vec4(cm_originView + cm_directionView * cm_first, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
