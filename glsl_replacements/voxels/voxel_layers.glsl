// requires: camera_declarations, pixel_ray, slab, voxel_declarations, voxel_layer_declarations,
// requires: layer_output_declarations
// Translucent materials: the layer actor's fragment (voxel_layer_declarations says what
// it draws), where VTK sets the depth; its colour is written after VTK's lighting.
{
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and index space
  cm_fragmentRay(cm_originView, cm_directionView, cm_origin, cm_direction);
#ifdef CM_LABEL_APRON
  // A ray lying in a chunk's border plane (an axis it does not move along, its origin on a
  // border within rounding) is put on it exactly, so the chunks on either side decide
  // alike: the one above draws it (boxes half-open below), not both or neither.
  vec3 cm_still = vec3(lessThan(abs(cm_direction), vec3(1e-6) * length(cm_direction)));
  vec3 cm_onBorder = cm_still * vec3(lessThan(abs(cm_origin), vec3(1e-4)))
                     + cm_still * vec3(lessThan(abs(cm_origin - cm_gridDims), vec3(1e-4)));
  cm_origin = mix(cm_origin, round(cm_origin), min(cm_onBorder, vec3(1.0)));
  cm_direction *= 1.0 - cm_still;
  if (dot(cm_still, vec3(greaterThanEqual(cm_origin, cm_gridDims))) > 0.0)
  {
    discard;
  }
#endif
  vec2 cm_inBox = cm_slab(cm_origin, cm_direction, vec3(0.0), cm_gridDims);
  float cm_boxEntry = cm_inBox.x;
  // Where a clip plane cuts the ray inside a translucent material, the cut is a face of it
  // (a clipped closed surface shows its cut, as PyVista's threshold + clip + add_mesh).
  bool cm_cutStart = false;
  bool cm_cutEnd = false;
#ifdef CM_CLIP_PLANES
  vec2 cm_box = cm_inBox;
  cm_inBox = cm_clipInterval(cm_origin, cm_direction, cm_inBox);   // the kept part
  float cm_nudge = 1e-4 / max(length(cm_direction), 1e-30);   // as voxel_fragment.glsl
  cm_cutStart = cm_inBox.x > cm_box.x && cm_inBox.x >= cm_near;
  cm_cutEnd = cm_inBox.y < cm_box.y;
  cm_inBox.x += cm_inBox.x > cm_box.x ? cm_nudge : 0.0;
  cm_inBox.y -= cm_inBox.y < cm_box.y ? cm_nudge : 0.0;
#endif
  float cm_start = max(cm_inBox.x, cm_near);
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  // The opaque depth as a view depth: the ray's parameter is the view depth (pixel_ray).
  float cm_opaque = -cm_viewPoint(cm_pixel * 2.0 - 1.0,
                                  texture(cm_sceneDepth, cm_pixel).r).z;
  // A hair past the box's exit or the opaque depth: the last face (on the grid's side, or
  // on an opaque voxel) is found by the traversal, which ends there (leaving the grid, an
  // opaque material), not lost to rounding.
  float cm_end = min(cm_inBox.y, cm_opaque) * (1.0 + 1e-4);
  if (cm_cutEnd && cm_inBox.y <= cm_opaque)
  {
    cm_end = cm_inBox.y;   // a plane ends it: no face past the plane (its cut is the last)
  }
  if (!(cm_end > cm_start))
  {
    discard;
  }
  vec3 cm_towardEye = -normalize(cm_directionView);
  ivec3 cm_dims = ivec3(cm_gridDims);
  // The ray measured from where it meets the box's planes, as the opaque traversal's
  // (voxel_fragment.glsl): t past the box's entry, so that the layers cross the voxels
  // the opaque actor's rays do, from any start (the box, the near plane, a clip plane).
  vec3 cm_a = cm_origin + cm_direction * cm_boxEntry;
  vec3 cm_d = cm_direction;
  float cm_tEnd = cm_end - cm_boxEntry;
  vec3 cm_moving = step(vec3(1e-30), abs(cm_d));
  vec3 cm_inverse = cm_moving / mix(vec3(1.0), cm_d, cm_moving);
  vec3 cm_never = 1e30 * (1.0 - cm_moving);
  vec3 cm_forward = step(vec3(0.0), cm_d);
  ivec3 cm_ahead = ivec3(cm_forward);
  ivec3 cm_voxel = cm_startVoxel(cm_a, cm_d, cm_inverse, cm_never, cm_forward,
                                 cm_start - cm_boxEntry, cm_dims);
  vec4 cm_held = vec4(0.0);
  float cm_first = -1.0;   // the view depth of the first layer
  int cm_current = cm_layerMaterial(cm_voxel);
  bool cm_throughFace = cm_boxEntry >= cm_start;   // entered through the box's face
#ifdef CM_LABEL_APRON
  // A world's chunk: a material going on from the neighbour behind that face has no face
  // there (each chunk draws the faces of its own voxels, so none is drawn twice).
  if (cm_throughFace && cm_current > 0)
  {
    int cm_entry = cm_boxEntryFace(cm_origin, cm_direction);
    ivec3 cm_before = cm_voxel;
    cm_before[cm_entry / 2] -= 2 * (cm_entry - 2 * (cm_entry / 2)) - 1;
    cm_throughFace = cm_layerMaterial(cm_before) != cm_current;
#ifdef CM_CLIP_PLANES
    // a plane on the box's face clips the neighbour away: this face is its cut
    cm_throughFace = cm_throughFace
                     || cm_clipKeeps(cm_origin + cm_direction * (cm_boxEntry - cm_nudge)) < 0.5;
#endif
  }
#endif
  if (cm_throughFace && cm_current != 0)
  {
    if (cm_current < 0)   // an opaque voxel first: the opaque actor draws it
    {
      discard;
    }
    cm_addLayer(cm_held, cm_current, cm_boxEntryFace(cm_origin, cm_direction),
                cm_originView + cm_directionView * cm_start, cm_towardEye);
    cm_first = cm_start;
  }
  else if (cm_current < 0)
  {
    discard;
  }
  else if (cm_current > 0 && cm_cutStart)   // the cut face of a translucent material
  {
#if defined(CM_CLIP_PLANES) && defined(CM_LIGHTING)
    cm_cutNormal = cm_clipNormalAt(cm_origin, cm_direction, cm_start);
#endif
    cm_addLayer(cm_held, cm_current, -1, cm_originView + cm_directionView * cm_start,
                cm_towardEye);
    cm_first = cm_start;
  }
  else if (cm_current > 0)
  {
    // Inside a translucent material (the near plane cuts it): its depth is the start's,
    // never the depth of an opaque face behind it (the depth test would flip a coin).
    cm_first = cm_start;
  }
  int cm_count = cm_dims.x + cm_dims.y + cm_dims.z + 3;   // no ray crosses more voxels
  for (int cm_i = 0; cm_i < cm_count && cm_held.a < 0.999; ++cm_i)
  {
    // Leave the voxel through its nearest forward boundary, x before y before z on a tie.
    vec3 cm_exits = (vec3(cm_voxel + cm_ahead) - cm_a) * cm_inverse + cm_never;
    int cm_axis = (cm_exits.x <= cm_exits.y && cm_exits.x <= cm_exits.z) ? 0
                  : (cm_exits.y <= cm_exits.z ? 1 : 2);
    float cm_t = min(cm_exits.x, min(cm_exits.y, cm_exits.z));
    if (cm_t > cm_tEnd)
    {
      // the opaque depth, the box's exit or a clip plane comes first: a plane's cut
      // through a translucent material is its last face
      if (cm_cutEnd && cm_current > 0 && cm_inBox.y <= cm_opaque)
      {
        if (cm_first < 0.0)
        {
          cm_first = cm_inBox.y;
        }
#if defined(CM_CLIP_PLANES) && defined(CM_LIGHTING)
        cm_cutNormal = cm_clipNormalAt(cm_origin, cm_direction, cm_inBox.y);
#endif
        cm_addLayer(cm_held, cm_current, -1, cm_originView + cm_directionView * cm_inBox.y,
                    cm_towardEye);
      }
      break;
    }
    ivec3 cm_next = cm_voxel;
    cm_next[cm_axis] += 2 * cm_ahead[cm_axis] - 1;
    bool cm_out = any(lessThan(cm_next, ivec3(0))) || any(greaterThanEqual(cm_next, cm_dims));
#ifdef CM_LABEL_APRON
    int cm_material = cm_layerMaterial(cm_next);   // past the box: the neighbour's voxel
#ifdef CM_CLIP_PLANES
    if (cm_out && cm_clipKeeps(cm_origin + cm_direction * (cm_boxEntry + cm_t + cm_nudge))
                  < 0.5)
    {
      cm_material = 0;   // a plane on the box's face clipped the neighbour away
    }
#endif
#else
    int cm_material = cm_out ? 0 : cm_layerMaterial(cm_next);
#endif
    if (cm_material != cm_current)
    {
      float cm_depth = cm_boxEntry + cm_t;
      vec3 cm_hitView = cm_originView + cm_directionView * cm_depth;
      int cm_face = 2 * cm_axis + cm_ahead[cm_axis];
      if (cm_first < 0.0 && (cm_current > 0 || cm_material > 0))
      {
        cm_first = cm_depth;
      }
      if (cm_current > 0)   // the face of the material left
      {
        cm_addLayer(cm_held, cm_current, cm_face, cm_hitView, cm_towardEye);
      }
      if (cm_material < 0)   // an opaque material: drawn already, behind
      {
        break;
      }
      if (cm_material > 0 && !cm_out)   // the face of the material entered (a
      {                                   // neighbour chunk's is drawn by that chunk)
        cm_addLayer(cm_held, cm_material, cm_face, cm_hitView, cm_towardEye);
      }
      cm_current = cm_material;
    }
    if (cm_out)
    {
      break;
    }
    cm_voxel = cm_next;
  }
  if (!(cm_held.a > 0.0))
  {
    discard;
  }
  cm_layerColor = vec4(cm_held.rgb / cm_held.a, cm_held.a);
  vec4 cm_clip = cm_projection * vec4(cm_originView + cm_directionView * cm_first, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
}
