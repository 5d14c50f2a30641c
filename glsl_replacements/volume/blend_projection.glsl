// What the intensity projections share (blend_maximum, blend_minimum): the ray keeps one
// value, state.x (state.y is 1 once a sample was read), and leaves it drawn with its
// colour and its opacity per unit distance (not accumulated), as VTK draws them.
uniform float cm_opacityUnit;   // the transfer function's opacity_unit_distance

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
