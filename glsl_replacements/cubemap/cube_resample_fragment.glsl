// Cube resampling pass (the cube map's pass 3) on the box's interior (back) faces, after VTK's
// lighting, which it replaces: this pixel's result from the cube map, blended over the
// scene by the translucent pass. Its ray stops at the nearer of the opaque depth and the
// face; the camera inside the box or the near plane cutting it need no special case.
{
#ifdef CM_OCCLUSION
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  float cm_stop = min(cm_viewDistance(cm_sceneDepthAt(cm_pixel)), cm_faceDistance);
  vec4 cm_rgba = cm_cubeLookup(cm_faceTexture, cm_stop);
#else
  vec4 cm_rgba = cm_cubeBilinear(cm_faceTexture);   // nothing opaque stops any ray
#endif
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  // Straight alpha for the translucent pass's blending: out = rgb * a + (1 - a) * dst.
  fragOutput0 = vec4(cm_rgba.rgb / cm_rgba.a, cm_rgba.a);
  gl_FragDepth = 0.0;   // drawn even where a mesh hides the face (no depth is written)
}
