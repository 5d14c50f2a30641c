// requires: blend_intensity
// Blending 'average': the mean of the opacity-weighted normalised values along the ray
// (state.x their sum, state.y how many), as a grey level; a ray that read no sample
// leaves the background. Samples outside cm_averageRange (the mapper's
// AverageIPScalarRange, stored units) are left out of both, as VTK leaves them.
uniform vec2 cm_averageRange;

vec4 cm_blendStart()
{
  return vec4(0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  float scalar = cm_sampleScalar(texturePosition);
  if (scalar >= cm_averageRange.x && scalar <= cm_averageRange.y)
  {
    state.x += cm_weightedValue(scalar);
    state.y += 1.0;
  }
  return true;
}

vec4 cm_blendResult(vec4 state)
{
  return state.y > 0.0 ? cm_greyResult(state.x / state.y) : vec4(0.0);
}
