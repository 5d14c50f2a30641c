// Debug view of a texture on a polydata actor: the colour written (after lighting).
{
  vec2 uv = gl_FragCoord.xy / cm_viewport;
#ifdef CM_VIEW_2D
  vec4 texel = texture(cm_viewTexture, uv);
#endif
#ifdef CM_VIEW_3D
  vec4 texel = texture(cm_viewTexture, vec3(uv, cm_slice));
#endif
#ifdef CM_VIEW_BUFFER
  int index = clamp(int(uv.x * float(cm_bufferLength)), 0, cm_bufferLength - 1);
  vec4 texel = vec4(texelFetch(cm_viewTexture, index).r);
#endif
  fragOutput0 = vec4((texel * cm_viewScale + cm_viewBias).rgb, 1.0);
}
