// The volume's data values as a 3D texture (texel centres on the grid points), for every
// shader that samples the data itself (VTK's mapper path brings its own sampler).
// CM_DIRECT_COLOR: an RGBA volume, uint8 normalised: rgb is the colour itself, alpha the
// value (0..255) that the transfer function makes opaque.
uniform sampler3D cm_volume;

#ifdef CM_DIRECT_COLOR
// The colour and the opacity's value (data units) at a texture position, in one read.
vec4 cm_sampleDirect(vec3 texturePosition)
{
  vec4 texel = texture(cm_volume, texturePosition);
  return vec4(texel.rgb, texel.a * 255.0);
}

float cm_sampleScalar(vec3 texturePosition)
{
  return texture(cm_volume, texturePosition).a * 255.0;
}
#else
float cm_sampleScalar(vec3 texturePosition)
{
  return texture(cm_volume, texturePosition).r;
}
#endif
