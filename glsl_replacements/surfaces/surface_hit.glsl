// requires: surface_shade_hit
  // The hit (cm_depth along the view ray, cm_local in the loaded cell cm_hitCell), opaque:
  // its colour (surface_shade_hit.glsl) and its real depth, so meshes and other techniques
  // occlude exactly.
  vec3 cm_hitView = cm_originView + cm_directionView * cm_depth;
#if defined(CM_SSAO) && !defined(CM_LIGHTING)
  // PyVista's SSAO reads each pixel's view position and normal; an unlit prop gives none,
  // as VTK's unlit meshes (no normals) do: SSAO leaves it as it is.
  fragOutput1 = vec4(0.0);
  fragOutput2 = vec4(0.0);
#elif defined(CM_SSAO)
  // PyVista's SSAO reads each pixel's view position and normal: the hit's, its normal as
  // it is lit (surface_shade_hit.glsl), not the domain box's; from the cell loaded for
  // the hit, before the colour may load another.
  fragOutput1 = vec4(cm_hitView, 1.0);
  fragOutput2 = vec4(cm_hitNormal(cm_local, cm_directionView), 1.0);
#endif
  fragOutput0 = vec4(cm_hitColor(cm_hitCell, cm_local, cm_hitView, cm_directionView), 1.0);
  vec4 cm_clip = cm_projection * vec4(cm_hitView, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
