// Blending 'maximum' (maximum-intensity projection): the largest scalar along the ray
// (drawn by blend_projection's cm_blendResult).
vec4 cm_blendStart()
{
  return vec4(-3.0e38, 0.0, 0.0, 0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  state.x = max(state.x, cm_sampleScalar(texturePosition));
  state.y = 1.0;
  return true;
}
