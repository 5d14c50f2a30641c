// requires: blend_opacity, ea_declarations
// Blending 'isosurface': each level of cm_isoValues the ray crosses between two samples is
// a surface with the colour and the opacity (per unit distance, not accumulated) the
// transfer function gives that level, composited front to back; samples between levels
// add nothing, as VTK's ISOSURFACE_BLEND draws it. The ray keeps which interval between
// levels its last sample lay in, so a sample costs one or two comparisons.
uniform float cm_isoValues[CM_ISO_COUNT];   // ascending, in the stored units

int cm_isoBelow;        // levels at or below the ray's last sample (-1: no sample yet)
#ifdef CM_SHADE
vec3 cm_shade(vec3 texturePosition, vec3 color);   // gradient_shading, after ea_march
#endif

vec4 cm_blendStart()
{
  cm_isoBelow = -1;
  return vec4(0.0);
}

// A level crossed: its colour (shaded, with CM_SHADE, by the gradient at the sample that
// crossed it, as VTK shades an isosurface) and its opacity.
void cm_isoHit(inout vec4 state, float level, vec3 texturePosition)
{
  float alpha = cm_opacityAt(level);
  vec3 color = cm_transfer(level).rgb;
#ifdef CM_SHADE
  color = cm_shade(texturePosition, color);
#endif
  state += (1.0 - state.a) * alpha * vec4(color, 1.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  float scalar = cm_sampleScalar(texturePosition);
  if (cm_isoBelow < 0)
  {
    cm_isoBelow = 0;
    for (int i = 0; i < CM_ISO_COUNT; ++i)
    {
      cm_isoBelow += cm_isoValues[i] <= scalar ? 1 : 0;
    }
    return true;
  }
  // Levels crossed since the last sample, in the order the ray meets them: up through
  // those strictly below this sample, or down through those strictly above it.
  for (int k = 0; k < CM_ISO_COUNT; ++k)
  {
    if (cm_isoBelow < CM_ISO_COUNT && scalar > cm_isoValues[cm_isoBelow])
    {
      cm_isoHit(state, cm_isoValues[cm_isoBelow], texturePosition);
      cm_isoBelow += 1;
    }
    else if (cm_isoBelow > 0 && scalar < cm_isoValues[cm_isoBelow - 1])
    {
      cm_isoHit(state, cm_isoValues[cm_isoBelow - 1], texturePosition);
      cm_isoBelow -= 1;
    }
    else
    {
      break;
    }
  }
  return !(state.a > cm_stopOpacity);
}

vec4 cm_blendResult(vec4 state)
{
  return state;
}
