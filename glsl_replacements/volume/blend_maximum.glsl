// Blending 'maximum' (maximum-intensity projection): the largest value along the ray (an
// RGBA volume: the largest alpha, with its colour), drawn by blend_projection.
vec4 cm_blendStart()
{
  return vec4(-3.0e38, 0.0, 0.0, 0.0);
}

bool cm_beyond(float value, float held)
{
  return value > held;
}
