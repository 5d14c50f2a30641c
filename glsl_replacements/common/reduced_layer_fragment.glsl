// requires: reduced_declarations
// The stand-in of a translucent prop drawn at reduced resolution (after VTK's lighting,
// which it replaces): the nearest texel's straight colour and alpha, composited over the
// frame by the overlay's blending; nothing where the prop drew nothing. What the prop drew
// already ends at the frame's opaque depth, so no depth test may drop any of it: the
// opaque depth written back from its float copy rounded above the 24-bit one at 3 % of
// the pixels over opaque voxels (the translucent faces in front of them lost).
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  ivec2 cm_texel = ivec2(min(cm_pixel * cm_reducedSize, cm_reducedSize - 1.0));
  vec4 cm_color = texelFetch(cm_reducedColor, cm_texel, 0);
  if (!(cm_color.a > 0.0))
  {
    discard;
  }
#ifdef CM_PREMULTIPLIED
  cm_color.rgb /= cm_color.a;   // many props' layers composited into the target, in order
#endif
  fragOutput0 = cm_color;
  gl_FragDepth = 0.0;   // nearest: kept by the test, not written (translucent pass)
}
