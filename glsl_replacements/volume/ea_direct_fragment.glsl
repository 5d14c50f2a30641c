// requires: ea_declarations, ea_direct_declarations, ea_march, screen_ray
// Direct screen-space marcher on a box actor: the ray, the march and the output colour
// (after VTK's lighting, which it replaces; under VTK's depth peeling, CM_PEELED_LAYER,
// where VTK sets the depth, so the peeling tests the fragment by the depth written here,
// the colour then written by layer_output.glsl).
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  vec3 cm_entry, cm_exit, cm_entryView, cm_exitView;
  if (!cm_screenRay(cm_pixel * 2.0 - 1.0, cm_sceneDepthAt(cm_pixel),
                    cm_entry, cm_exit, cm_entryView, cm_exitView))
  {
    discard;
  }
  vec4 cm_rgba = cm_march(cm_entry, cm_exit,
                          cm_mediumLength(cm_exit - cm_entry));
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  // Blended as straight alpha by VTK's translucent pass: out = rgb * a + (1 - a) * dst.
#ifdef CM_PEELED_LAYER
  cm_layerColor = vec4(cm_rgba.rgb / cm_rgba.a, cm_rgba.a);
#else
  fragOutput0 = vec4(cm_rgba.rgb / cm_rgba.a, cm_rgba.a);
#endif
#ifdef CM_SSAO
  // PyVista's SSAO reads each pixel's view position and normal: a translucent fragment
  // gives none (alpha 0: the blend keeps what lies behind), not its box's face.
  fragOutput1 = vec4(0.0);
  fragOutput2 = vec4(0.0);
#endif
  vec4 cm_clip = cm_projection * vec4(cm_entryView, 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
}
