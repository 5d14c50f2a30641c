// Blending 'isosurface': each level of cm_isoValues the ray crosses between two samples is
// a surface with the colour and the opacity (per unit distance, not accumulated) the
// transfer function gives that level, composited front to back; samples between levels
// add nothing, as VTK's ISOSURFACE_BLEND draws it.
uniform float cm_isoValues[CM_ISO_COUNT];   // ascending, in the stored units

float cm_isoPrevious;   // the ray's last sample
bool cm_isoStarted;     // whether it has one

vec4 cm_blendStart()
{
  cm_isoStarted = false;
  return vec4(0.0);
}

void cm_isoHit(inout vec4 state, float level)
{
  float alpha = cm_opacityAt(level);
  state += (1.0 - state.a) * alpha * vec4(cm_transfer(level).rgb, 1.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  float scalar = cm_sampleScalar(texturePosition);
  if (cm_isoStarted)
  {
    // Levels crossed in the order the ray meets them.
    for (int i = 0; i < CM_ISO_COUNT; ++i)
    {
      int up = i;
      int down = CM_ISO_COUNT - 1 - i;
      if (scalar > cm_isoPrevious && cm_isoPrevious < cm_isoValues[up] &&
          cm_isoValues[up] < scalar)
      {
        cm_isoHit(state, cm_isoValues[up]);
      }
      if (scalar < cm_isoPrevious && cm_isoValues[down] <= cm_isoPrevious &&
          scalar < cm_isoValues[down])
      {
        cm_isoHit(state, cm_isoValues[down]);
      }
    }
  }
  cm_isoStarted = true;
  cm_isoPrevious = scalar;
  return !(state.a > cm_stopOpacity);
}

vec4 cm_blendResult(vec4 state)
{
  return state;
}
