// requires: reduced_declarations
// The stand-in of a prop drawn at reduced resolution (after VTK's lighting, which it
// replaces): the nearest texel's colour and window depth, so the depth test between it and
// the scene's other props is the prop's own; nothing where the prop drew nothing.
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  ivec2 cm_texel = ivec2(min(cm_pixel * cm_reducedSize, cm_reducedSize - 1.0));
  float cm_depth = texelFetch(cm_reducedDepth, cm_texel, 0).r;
  if (!(cm_depth < 1.0))
  {
    discard;
  }
  fragOutput0 = texelFetch(cm_reducedColor, cm_texel, 0);
  gl_FragDepth = cm_depth;
}
