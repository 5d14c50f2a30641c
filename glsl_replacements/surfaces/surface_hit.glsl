  // The hit (cm_depth along the view ray, cm_local in the loaded cell cm_hitCell): the
  // analytic gradient's normal (pointing out: the field is positive inside), turned to the
  // side facing the eye and lit there, and the hit's real depth, so meshes and other
  // techniques occlude exactly. The normal is taken first: a second field's value may
  // replace the loaded cell. CM_NORMAL_COLORS (shading 'normals') shows the view-space
  // normal as 0.5 + 0.5 n.
  vec3 cm_hitView = cm_originView + cm_directionView * cm_depth;
#if defined(CM_LIGHTING) || defined(CM_NORMAL_COLORS)
  vec3 cm_towardEye = -normalize(cm_directionView);
  vec3 cm_normal = normalize(cm_normalFromIndex * -cm_fieldGradient(cm_local));
  cm_normal = dot(cm_normal, cm_towardEye) < 0.0 ? -cm_normal : cm_normal;
#endif
  vec3 cm_albedo = cm_surfaceColor;
#ifdef CM_COLOR_BY_CURVATURE
  cm_albedo = cm_colorOf(cm_meanCurvature(cm_local));
#endif
#ifdef CM_COLOR_VALUES
  cm_albedo = cm_colorOf(cm_colorValue(cm_hitCell, cm_local));
#endif
#if defined(CM_NORMAL_COLORS)
  fragOutput0 = vec4(0.5 + 0.5 * cm_normal, 1.0);
#elif defined(CM_LIGHTING)
  fragOutput0 = vec4(cm_shade(cm_albedo, cm_normal, cm_hitView, cm_towardEye), 1.0);
#else
  fragOutput0 = vec4(cm_albedo, 1.0);
#endif
  vec4 cm_clip = cm_projection * vec4(cm_hitView, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
