// requires: ea_declarations, ea_march
// Blending 'composite': emission/absorption, front to back, with early ray termination.
// A blend mode defines the ray's running state, how a sample enters it (false: stop the ray)
// and the premultiplied rgba it leaves; the marcher (ea_march) calls these three.
vec4 cm_emission(vec3 texturePosition);   // defined by ea_march

#ifdef CM_STOP_DEPTH
// Where the ray stopped (texture coordinates of its last sample), once cm_stopped.
vec3 cm_stopPosition;
bool cm_stopped = false;
#endif

vec4 cm_blendStart()
{
  return vec4(0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  cm_composite(state, cm_emission(texturePosition), dt);
  bool goOn = !(state.a > cm_stopOpacity);
#ifdef CM_STOP_DEPTH
  if (!goOn)
  {
    cm_stopPosition = texturePosition;
    cm_stopped = true;
  }
#endif
  return goOn;
}

vec4 cm_blendResult(vec4 state)
{
  return state;
}
