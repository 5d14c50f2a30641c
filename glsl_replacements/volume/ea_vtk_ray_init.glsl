// requires: ea_declarations, ea_march, screen_ray
// Emission/absorption in VTK's volume mapper (the shading-init tag). The ray is set up here,
// not by VTK: from the fragment's window position through the camera-relative matrices the
// direct marcher uses (made in double precision on the CPU), from the near plane to the box
// or the opaque depth (VTK's own copy of it). VTK's set-up multiplies world-sized float32
// matrices and positions, which loses the ray far from the origin. We march the ray whole
// with the shared marcher and leave VTK's own loop before it starts.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  float cm_depth = texture(in_depthSampler,
                           (gl_FragCoord.xy - in_windowLowerLeftCorner) * in_inverseWindowSize).r;
  vec3 cm_entry, cm_exit, cm_entryView, cm_exitView;
  g_fragColor = vec4(0.0);
  if (cm_screenRay(cm_pixel * 2.0 - 1.0, cm_depth, cm_entry, cm_exit, cm_entryView,
                   cm_exitView))
  {
    g_fragColor = cm_march(cm_entry, cm_exit,
                           cm_mediumLength(cm_exit - cm_entry));
  }
  g_exit = true;
}
