// requires: camera_declarations, ea_declarations, ea_march, screen_ray
// Reduced-resolution emission/absorption pass: one ray per texel of a target 1/k of the
// viewport, up to the far plane or the opaque depth. Target 0: premultiplied rgba;
// target 1: view z where the ray stops (the key of the depth-aware upsampling).
void main()
{
  float sceneDepth = texture(cm_sceneDepth, texCoord).r;
  vec3 entry, exit, entryView, exitView;
  vec4 rgba = vec4(0.0);
  if (cm_screenRay(texCoord * 2.0 - 1.0, sceneDepth, entry, exit, entryView, exitView))
  {
    rgba = cm_march(entry, exit, cm_mediumLength(exit - entry));
  }
  gl_FragData[0] = rgba;
  gl_FragData[1] = vec4(cm_viewPoint(texCoord * 2.0 - 1.0, sceneDepth).z, 0.0, 0.0, 1.0);
}
