// requires: camera_declarations, ea_upsample_declarations, screen_ray
// Depth-aware upsampling of the reduced-resolution pass on the box's back faces (after
// VTK's lighting, which it replaces): composites the low-resolution result over the scene.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  float cm_depth = texture(cm_sceneDepth, cm_pixel).r;
  vec3 cm_entry, cm_exit, cm_entryView, cm_exitView;
  if (!cm_screenRay(cm_pixel * 2.0 - 1.0, cm_depth,
                    cm_entry, cm_exit, cm_entryView, cm_exitView))
  {
    discard;
  }
  vec4 cm_rgba = cm_upsample(cm_pixel, cm_viewPoint(cm_pixel * 2.0 - 1.0, cm_depth).z);
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  // Composite over a copy of the scene and write an opaque result: right whatever blending
  // the overlay's pass uses. The rays already stopped at the scene's depth, so nothing may
  // hide this fragment.
  vec3 cm_under = texture(cm_sceneColor, cm_pixel).rgb;
  fragOutput0 = vec4(cm_rgba.rgb + (1.0 - cm_rgba.a) * cm_under, 1.0);
  gl_FragDepth = 0.0;
}
