// What the intensity projections share (blend_maximum, blend_minimum): the ray keeps the
// sample its mode's cm_beyond prefers (the first of equals, as VTK keeps it) and leaves it
// drawn with its colour and its opacity per unit distance (cm_opacityAt), as VTK draws
// them. state.x is the kept value; a scalar volume sets state.y once a sample was read, an
// RGBA volume (CM_DIRECT_COLOR) keeps the extreme alpha and that sample's own colour in
// state.yzw (no alpha lies beyond cm_blendStart's +-3e38, so none read leaves it there).
bool cm_beyond(float value, float held);   // blend_maximum / blend_minimum

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
#ifdef CM_DIRECT_COLOR
  vec4 direct = cm_sampleDirect(texturePosition);
  if (cm_beyond(direct.a, state.x))
  {
    state = vec4(direct.a, direct.rgb);
  }
#else
  float value = cm_sampleScalar(texturePosition);
  if (cm_beyond(value, state.x))
  {
    state.x = value;
  }
  state.y = 1.0;
#endif
  return true;
}

vec4 cm_blendResult(vec4 state)
{
#ifdef CM_DIRECT_COLOR
  if (abs(state.x) > 1.0e38)
  {
    return vec4(0.0);
  }
  float alpha = cm_opacityAt(state.x);
  return vec4(state.yzw * alpha, alpha);
#else
  if (state.y == 0.0)
  {
    return vec4(0.0);
  }
  float alpha = cm_opacityAt(state.x);
  return vec4(cm_transfer(state.x).rgb * alpha, alpha);
#endif
}
