// requires: blend_intensity
// Blending 'additive': the opacity-weighted normalised values summed along the ray, each
// times its length over opacity_unit_distance (a path integral), as a grey level clamped
// to 1; every ray that crosses the volume leaves it, zero included.
vec4 cm_blendStart()
{
  return vec4(0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  state.x += cm_weightedValue(cm_sampleScalar(texturePosition)) * dt / cm_opacityUnit;
  return true;
}

vec4 cm_blendResult(vec4 state)
{
  return cm_greyResult(state.x);
}
