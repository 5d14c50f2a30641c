// Blending 'maximum' (maximum-intensity projection, as VTK's): the largest scalar along the
// ray, drawn with its colour and its opacity per unit distance (not accumulated).
uniform float cm_opacityUnit;   // the transfer function's opacity_unit_distance

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

vec4 cm_blendResult(vec4 state)
{
  if (state.y == 0.0)
  {
    return vec4(0.0);
  }
  vec4 emission = cm_transfer(state.x);
  float alpha = 1.0 - exp(-emission.a * cm_opacityUnit);
  return vec4(emission.rgb * alpha, alpha);
}
