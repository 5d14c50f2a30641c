// Emission/absorption in VTK's volume mapper: reading a data value from VTK's volume texture.
// VTK's scale and bias map the stored value to [0, 1] over the data's scalar range; we map it
// back to a data value for our own transfer table. CM_DIRECT_COLOR: VTK's texture holds an
// RGBA volume's 4 dependent uint8 components, normalised over 0..255 (rgb is the colour as
// VTK draws it); alpha, times 255, is the value. (VTK's own opacity reads it as if it were
// normalised over the alpha's range instead: its opacity depends on the largest alpha.)
#ifdef CM_DIRECT_COLOR
vec4 cm_sampleDirect(vec3 texturePosition)
{
  vec4 unit = texture(in_volume[0], texturePosition) * in_volume_scale[0] + in_volume_bias[0];
  return vec4(unit.rgb, unit.a * 255.0);
}

float cm_sampleScalar(vec3 texturePosition)
{
  return cm_sampleDirect(texturePosition).a;
}
#else
float cm_sampleScalar(vec3 texturePosition)
{
  float unit = texture(in_volume[0], texturePosition).r * in_volume_scale[0].r
    + in_volume_bias[0].r;
  return mix(in_scalarsRange[0].x, in_scalarsRange[0].y, unit);
}
#endif
