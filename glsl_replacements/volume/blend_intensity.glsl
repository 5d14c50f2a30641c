// requires: blend_opacity
// What 'average' and 'additive' share: a sample's value normalised over the data's range
// (not clim), weighted by its opacity; the ray leaves a grey level, opaque, as VTK draws
// these modes (the colour map is not read).
uniform vec2 cm_dataRange;      // the smallest and largest value of the data

float cm_weightedValue(float scalar)
{
  float width = cm_dataRange.y - cm_dataRange.x;
  float normalised = width > 0.0 ? (scalar - cm_dataRange.x) / width : 0.0;
  return cm_opacityAt(scalar) * normalised;
}

vec4 cm_greyResult(float level)
{
  return vec4(vec3(clamp(level, 0.0, 1.0)), 1.0);
}
