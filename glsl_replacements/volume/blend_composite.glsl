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

#ifdef CM_PIXEL_STOP
// The stop opacity of this pixel's ray, set by the main (a sort-last slab's: the opacity
// the slabs in front of it leave to reach before the whole ray stops).
float cm_rayStopOpacity = 1.0;
#define CM_RAY_STOP_OPACITY cm_rayStopOpacity
#else
#define CM_RAY_STOP_OPACITY cm_stopOpacity
#endif

vec4 cm_blendStart()
{
  return vec4(0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  cm_composite(state, cm_emission(texturePosition), dt);
  bool goOn = !(state.a > CM_RAY_STOP_OPACITY);
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
