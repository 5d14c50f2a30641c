// Emission/absorption in VTK's volume mapper: reading a data value from VTK's volume texture.
// VTK's scale and bias map the stored value to [0, 1] over the data's scalar range; we map it
// back to a data value for our own transfer table.
float cm_sampleScalar(vec3 texturePosition)
{
  float unit = texture(in_volume[0], texturePosition).r * in_volume_scale[0].r
    + in_volume_bias[0].r;
  return mix(in_scalarsRange[0].x, in_scalarsRange[0].y, unit);
}
