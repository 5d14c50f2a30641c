// Cube resampling pass (000 pass 3) on the box's interior (back) faces, after VTK's
// lighting, which it replaces: fetch this pixel's result from the cube map and composite it
// over the scene. The camera inside the box or the near plane cutting it need no special
// case: the interior faces are always behind the eye's rays.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  vec2 cm_ndc = cm_pixel * 2.0 - 1.0;
  vec3 cm_entry, cm_exit, cm_entryView, cm_exitView;
  if (!cm_screenRay(cm_ndc, gl_FragCoord.z, cm_sceneDepthAt(cm_pixel),
                    cm_entry, cm_exit, cm_entryView, cm_exitView))
  {
    discard;
  }
  vec3 cm_onFace = (cm_textureFromView * vec4(cm_viewPoint(cm_ndc, gl_FragCoord.z), 1.0)).xyz;
  vec4 cm_rgba = cm_cubeLookup(cm_onFace, -cm_exitView.z);
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  // Composite over a copy of the scene and write an opaque result (as the upsampling does).
  vec3 cm_under = texture(cm_sceneColor, cm_pixel).rgb;
  fragOutput0 = vec4(cm_rgba.rgb + (1.0 - cm_rgba.a) * cm_under, 1.0);
  gl_FragDepth = 0.0;
}
