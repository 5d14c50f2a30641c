// The volume's data values as a 3D texture (texel centres on the grid points), for every
// shader that samples the data itself (VTK's mapper path brings its own sampler).
uniform sampler3D cm_volume;

float cm_sampleScalar(vec3 texturePosition)
{
  return texture(cm_volume, texturePosition).r;
}
