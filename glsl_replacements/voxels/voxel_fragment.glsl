// requires: camera_declarations, pixel_ray, slab, voxel_declarations
// Material grid on its box actor (opaque pass, back faces; after VTK's lighting, which it
// replaces): this pixel's ray (pixel_ray.glsl) through the grid's box (cm_slab), from the
// box, the near plane or the brick shell (its depth pass), traversed to the first drawn
// voxel; its colour (the palette's, lit with CM_LIGHTING, the voxel's id with CM_VOXEL_ID,
// its entered face with CM_VOXEL_FACE) and the real depth of the hit, so meshes and other
// techniques occlude and are occluded exactly.
{
#ifdef CM_SHELL_LEVEL
  // Where the ray meets the brick shell (its depth pass), first: a pixel that meets none
  // is done before any other work.
  float cm_shell = cm_near;
  if (cm_startAtProxy > 0.5)
  {
    cm_shell = texelFetch(cm_shellDepth, ivec2(gl_FragCoord.xy - cm_viewport.xy), 0).r;
    if (cm_shell > 1e29)
    {
      discard;
    }
  }
#endif
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and index space
  cm_fragmentRay(cm_originView, cm_directionView, cm_origin, cm_direction);
  vec2 cm_inBox = cm_slab(cm_origin, cm_direction, vec3(0.0), CM_TRAVERSED_DIMS);
  float cm_boxEntry = cm_inBox.x;
#ifdef CM_CLIP_PLANES
  // The part of the ray the clip planes keep (clip_planes.glsl, index-space planes): a
  // ray starting on a plane inside a filled voxel draws that voxel there.
  vec2 cm_box = cm_inBox;
  cm_inBox = cm_clipInterval(cm_origin, cm_direction, cm_inBox);
  // A plane on a voxel face: the voxel ahead of the ray's start is drawn, the one just
  // past its end is not (as the CPU traversal); 1e-4 voxel keeps float32 from striping.
  float cm_nudge = 1e-4 / max(length(cm_direction), 1e-30);
  cm_inBox.x += cm_inBox.x > cm_box.x ? cm_nudge : 0.0;
  cm_inBox.y -= cm_inBox.y < cm_box.y ? cm_nudge : 0.0;
#endif
  // No hit past the far plane (as VTK clips a mesh there): the box is drawn pulled onto
  // it (ea_box_vertex.glsl), and its rays end there.
  cm_inBox.y = min(cm_inBox.y, cm_viewDepthOf(1.0));
  // From the box or the near plane; with the brick shell, from where the ray meets it
  // (every voxel before that is empty), and not at all where it meets none.
  float cm_start = max(cm_inBox.x, cm_near);
#ifdef CM_SHELL_LEVEL
  cm_start = max(cm_start, cm_shell);
#endif
#ifdef CM_OCCLUDERS
  // A world's chunk: no ray passes the nearest solid face (voxels/occluders.py) without
  // a hit, so rays end there and a chunk hidden behind it is done here.
  if (cm_useOccluders > 0.5)
  {
    cm_inBox.y = min(cm_inBox.y, texelFetch(cm_occluderDepth,
                                            ivec2(gl_FragCoord.xy - cm_viewport.xy), 0).r);
  }
#endif
  if (!(cm_inBox.y > cm_start))
  {
    discard;
  }
  // The ray measured from where it meets the box's planes (whatever its start: the near
  // plane, a clip plane, the shell), so that a ray's voxels are the same from any start.
  vec3 cm_a = cm_origin + cm_direction * cm_boxEntry;
  // The face of the grid box the ray enters through (-1 when it starts inside the box).
  int cm_face = cm_boxEntry >= cm_start ? cm_boxEntryFace(cm_origin, cm_direction) : -1;
  ivec3 cm_voxel;
  float cm_t;
#ifdef CM_LOD
  cm_drawLevel = cm_lodLevel(cm_start);
#endif
  int cm_material = cm_voxelTraverse(cm_a, cm_direction, cm_start - cm_boxEntry,
                                     cm_inBox.y - cm_boxEntry, cm_voxel, cm_face, cm_t);
  if (cm_material == 0)
  {
    discard;
  }
#if defined(CM_CLIP_PLANES) && defined(CM_LIGHTING)
  if (cm_face < 0 && cm_inBox.x > cm_box.x && cm_start <= cm_inBox.x)   // on a plane's cut
  {
    cm_cutNormal = cm_clipNormalAt(cm_origin, cm_direction, cm_start);
  }
#endif
#ifdef CM_VOXEL_ID
  ivec3 cm_dims3 = ivec3(CM_TRAVERSED_DIMS);
  int cm_id = cm_voxel.x + cm_dims3.x * (cm_voxel.y + cm_dims3.y * cm_voxel.z) + 1;
  fragOutput0 = vec4(float(cm_id & 255), float((cm_id >> 8) & 255),
                     float((cm_id >> 16) & 255), 255.0) / 255.0;
#endif
#ifdef CM_VOXEL_FACE
  fragOutput0 = vec4(float(32 * (cm_face + 2)) / 255.0, 0.0, 0.0, 1.0);
#endif
  float cm_depth = cm_boxEntry + cm_t;   // the hit's view depth
  vec3 cm_hitIndex = cm_a + cm_direction * cm_t;
  vec3 cm_hitView = cm_originView + cm_directionView * cm_depth;
#if !defined(CM_VOXEL_ID) && !defined(CM_VOXEL_FACE)
  vec3 cm_color = cm_paletteEntry(cm_material).rgb;
#ifdef CM_OCCLUSION
  // The entered face's ambient occlusion (voxel_occlusion.glsl) at the index-space hit: it
  // scales the colour before lighting, so the ambient + diffuse term, not the highlight.
  cm_color *= cm_voxelOcclusion(cm_voxel, cm_face, cm_hitIndex);
#endif
#ifdef CM_EDGES
  // The edges (voxel_edges.glsl) take the unlit colour and the diffuse term, not the
  // highlight: the highlight is the shading of black.
#ifdef CM_EDGE_LABELS
  float cm_edge = cm_labelEdgeCoverage(cm_voxel, cm_face, cm_hitIndex,
                                       cm_material);
#else
  float cm_edge = cm_edgeCoverage(cm_voxel, cm_face, cm_hitIndex);
#endif
#ifdef CM_LIGHTING
  vec3 cm_towardEye = -normalize(cm_directionView);
  cm_color = cm_shadeVoxel(cm_color, cm_face, cm_hitView, cm_towardEye);
  if (cm_edge > 0.0)   // the highlight alone, only where an edge covers the pixel
  {
    vec3 cm_highlight = cm_shadeVoxel(vec3(0.0), cm_face, cm_hitView, cm_towardEye);
    cm_color = clamp(mix(cm_color - cm_highlight, cm_edgeColor, cm_edge) + cm_highlight,
                     0.0, 1.0);
  }
#else
  cm_color = mix(cm_color, cm_edgeColor, cm_edge);
#endif
#elif defined(CM_LIGHTING)
  cm_color = cm_shadeVoxel(cm_color, cm_face, cm_hitView, -normalize(cm_directionView));
#endif
  fragOutput0 = vec4(cm_color, 1.0);
#endif
  vec4 cm_clip = cm_projection * vec4(cm_hitView, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
#if defined(CM_SSAO) && !defined(CM_LIGHTING)
  // PyVista's SSAO reads each pixel's view position and normal; an unlit prop gives none,
  // as VTK's unlit meshes (no normals) do: SSAO leaves it as it is.
  fragOutput1 = vec4(0.0);
  fragOutput2 = vec4(0.0);
#elif defined(CM_SSAO)
  // PyVista's SSAO reads each pixel's view position and normal: the hit's, and its
  // entered face's (voxel_shading.glsl, as it is lit), not the box's.
  fragOutput1 = vec4(cm_hitView, 1.0);
  fragOutput2 = vec4(cm_voxelFaceNormal(cm_face, -normalize(cm_directionView)), 1.0);
#endif
}
