// What the intensity projections share (blend_maximum, blend_minimum): the ray keeps one
// value, state.x (state.y is 1 once a sample was read), and leaves it drawn with its
// colour and its opacity per unit distance (cm_opacityAt), as VTK draws them.
vec4 cm_blendResult(vec4 state)
{
  if (state.y == 0.0)
  {
    return vec4(0.0);
  }
  float alpha = cm_opacityAt(state.x);
  return vec4(cm_transfer(state.x).rgb * alpha, alpha);
}
