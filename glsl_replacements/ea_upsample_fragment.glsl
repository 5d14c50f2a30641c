// Depth-aware upsampling of the reduced-resolution pass on the box's back faces (after
// VTK's lighting, which it replaces): composites the low-resolution result over the scene.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  float cm_depth = texture(cm_sceneDepth, cm_pixel).r;
  vec3 cm_entry, cm_exit, cm_entryView, cm_exitView;
  if (!cm_screenRay(cm_pixel * 2.0 - 1.0, gl_FragCoord.z, cm_depth,
                    cm_entry, cm_exit, cm_entryView, cm_exitView))
  {
    discard;
  }
  vec4 cm_rgba = cm_upsample(cm_pixel, cm_viewPoint(cm_pixel * 2.0 - 1.0, cm_depth).z);
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  fragOutput0 = vec4(cm_rgba.rgb / cm_rgba.a, cm_rgba.a);
  vec4 cm_clip = cm_projection * vec4(cm_entryView, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
}
