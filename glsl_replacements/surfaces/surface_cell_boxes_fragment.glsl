// requires: camera_declarations, pixel_ray, slab, surface_records
// Active cells drawn as boxes (traversal 'cell_boxes'):
// each fragment of an active cell's back faces marches its pixel's ray within that cell
// only, from where the ray enters it (or the near plane: the camera inside the cell) to
// where it leaves; the depth test keeps the nearest hit of all cells along the ray. The
// cell is the primitive's: 12 triangles each, in the order of cm_cells. Followed by
// surface_hit.glsl (one block of main: cm_ names).
  int cm_cell = gl_PrimitiveID / 12;
  int cm_base = cm_cell * CM_CELL_FLOATS;
  vec3 cm_corner = vec3(texelFetch(cm_cells, cm_base).r, texelFetch(cm_cells, cm_base + 1).r,
                        texelFetch(cm_cells, cm_base + 2).r);
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and cell space
  cm_fragmentRay(cm_originView, cm_directionView, cm_origin, cm_direction);
  cm_origin -= cm_corner;   // the cell's own coordinates
  // The cell's slab grown by 1e-4 cell: a pixel the rasteriser gives this cell may have a
  // ray exactly on its edge that float32 puts an ulp outside (seen: holes along cell lines
  // in an axis-aligned parallel view); the polynomial extends smoothly past the cell.
  vec2 cm_span = cm_slab(cm_origin, cm_direction, vec3(-1e-4), vec3(1.0 + 1e-4));
#ifdef CM_DOMAIN_CUT
  // a cell at the grid's face is cut to the domain (the points' hull), as contour stops
  vec2 cm_inDomain = cm_slab(cm_origin, cm_direction, cm_domainLower - cm_corner - vec3(1e-4),
                             cm_domainUpper - cm_corner + vec3(1e-4));
  cm_span = vec2(max(cm_span.x, cm_inDomain.x), min(cm_span.y, cm_inDomain.y));
#endif
  float cm_start = max(cm_span.x, cm_near);
  cm_span.y = min(cm_span.y, cm_viewDepthOf(1.0));   // nothing past the far plane
#ifdef CM_CLIP_PLANES
  vec2 cm_kept = cm_clipInterval(cm_origin + cm_corner, cm_direction,
                                 vec2(cm_start, cm_span.y));   // planes in the grid's cells
  cm_start = cm_kept.x;
  cm_span.y = cm_kept.y;
#endif
  if (!(cm_span.y > cm_start))
  {
    discard;
  }
  cm_loadCell(cm_cell);
  vec3 cm_a = cm_origin + cm_direction * cm_start;
  vec3 cm_b = cm_origin + cm_direction * cm_span.y;
#ifdef CM_EXACT_ROOT
  float cm_s = cm_exactRoot(cm_a, cm_b);
#else
  float cm_s = cm_marchCell(cm_a, cm_b);
#endif
  if (cm_s < 0.0)
  {
    discard;
  }
  float cm_depth = mix(cm_start, cm_span.y, cm_s);
  vec3 cm_local = clamp(mix(cm_a, cm_b, cm_s), 0.0, 1.0);
  int cm_hitCell = cm_cell;
