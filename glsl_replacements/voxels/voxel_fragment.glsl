// Material grid on its box actor (opaque pass, back faces; after VTK's lighting, which it
// replaces): this pixel's ray from the near plane through the grid's box, traversed to the
// first drawn voxel; its colour (palette, or the voxel's id with CM_VOXEL_ID) and the real
// depth of the hit, so meshes and other techniques occlude and are occluded exactly.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  vec3 cm_a, cm_b, cm_aView, cm_bView;
  if (!cm_screenRayBox(cm_pixel * 2.0 - 1.0, gl_FragCoord.z, 1.0, vec3(0.0), cm_gridDims,
                       cm_a, cm_b, cm_aView, cm_bView))
  {
    discard;
  }
  ivec3 cm_voxel;
  int cm_face;
  float cm_t;
  int cm_material = cm_voxelTraverse(cm_a, cm_b, cm_voxel, cm_face, cm_t);
  if (cm_material == 0)
  {
    discard;
  }
#ifdef CM_VOXEL_ID
  ivec3 cm_dims3 = ivec3(cm_gridDims);
  int cm_id = cm_voxel.x + cm_dims3.x * (cm_voxel.y + cm_dims3.y * cm_voxel.z) + 1;
  fragOutput0 = vec4(float(cm_id & 255), float((cm_id >> 8) & 255),
                     float((cm_id >> 16) & 255), 255.0) / 255.0;
#else
  fragOutput0 = vec4(texelFetch(cm_palette, ivec2(cm_material, 0), 0).rgb, 1.0);
#endif
  vec4 cm_clip = cm_projection * vec4(mix(cm_aView, cm_bView, cm_t), 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
}
