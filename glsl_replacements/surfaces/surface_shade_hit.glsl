// The colour of a hit, shared by the opaque fragments (surface_hit.glsl) and the
// translucent layers (surface_layers_fragment.glsl). The albedo is read first from the hit
// cell: a second field's value may replace the loaded cell (CM_COLOR_VALUES).
#ifdef CM_BRICK_SHIFT
#define CM_HIT_CELL ivec3   // traversal 'index': the cell itself
#else
#define CM_HIT_CELL int     // records: the cell's number
#endif

// The surface's colour at local `local` of the loaded cell `cell`, before lighting.
vec3 cm_hitAlbedo(CM_HIT_CELL cell, vec3 local)
{
  vec3 albedo = cm_surfaceColor;
#ifdef CM_LEVELS
  albedo = vec3(cm_levelColors[3 * cm_rootLevel], cm_levelColors[3 * cm_rootLevel + 1],
                cm_levelColors[3 * cm_rootLevel + 2]);
#endif
#ifdef CM_COLOR_BY_CURVATURE
  albedo = cm_colorOf(cm_meanCurvature(local));
#endif
#ifdef CM_COLOR_VALUES
  albedo = cm_colorOf(cm_colorValue(cell, local));
#endif
  return albedo;
}

// The hit's colour: the analytic gradient's normal (pointing out: the field is positive
// inside), turned to the side facing the eye and lit there (both sides lit, as VTK's
// two-sided lighting); CM_NORMAL_COLORS (shading 'normals') shows the view-space normal as
// 0.5 + 0.5 n. The normal is taken from the loaded cell before the albedo is read.
#if defined(CM_LIGHTING) || defined(CM_NORMAL_COLORS)
// The hit's view-space normal, turned to the eye, from the loaded cell.
vec3 cm_hitNormal(vec3 local, vec3 directionView)
{
  vec3 normal = normalize(cm_normalFromIndex * -cm_fieldGradient(local));
  return dot(normal, directionView) > 0.0 ? -normal : normal;
}
#endif

vec3 cm_hitColor(CM_HIT_CELL cell, vec3 local, vec3 hitView, vec3 directionView)
{
#if defined(CM_LIGHTING) || defined(CM_NORMAL_COLORS)
  vec3 towardEye = -normalize(directionView);
  vec3 normal = cm_hitNormal(local, directionView);
#endif
  vec3 albedo = cm_hitAlbedo(cell, local);
#if defined(CM_NORMAL_COLORS)
  return 0.5 + 0.5 * normal;
#elif defined(CM_LIGHTING)
  return cm_shade(albedo, normal, hitView, towardEye);
#else
  return albedo;
#endif
}
