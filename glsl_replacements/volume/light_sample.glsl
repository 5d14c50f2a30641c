// Lit emission (the light map's read side): the emitted colour of a sample is scaled by
//   ambient + (1 - ambient) * sum over lights of colour_i * transmittance_i(sample),
// the transmittances read from the light map by trilinear interpolation. Needs cm_dims.
uniform sampler2D cm_lightMap;   // L slices of L x L stacked along y; rgba = lights 0..3
uniform float cm_lightMapSize;   // L, light-map points per axis (>= 2)
uniform mat4 cm_lightColors;     // column i: colour times intensity of light i
uniform float cm_ambient;        // share of the emission that no light modulates

// Transmittance toward each light at a texture position (points of the light map span the
// box of texel centres, corners included).
vec4 cm_lightTransmittance(vec3 texturePosition)
{
  float size = cm_lightMapSize;
  vec3 unit = clamp((texturePosition * cm_dims - 0.5) / max(cm_dims - 1.0, vec3(1.0)),
                    0.0, 1.0);
  vec3 grid = unit * (size - 1.0);
  float slice = min(floor(grid.z), size - 2.0);
  float x = (grid.x + 0.5) / size;
  float rows = size * size;
  vec4 below = texture(cm_lightMap, vec2(x, (slice * size + grid.y + 0.5) / rows));
  vec4 above = texture(cm_lightMap, vec2(x, ((slice + 1.0) * size + grid.y + 0.5) / rows));
  return mix(below, above, grid.z - slice);
}

vec3 cm_lighting(vec3 texturePosition)
{
  vec4 transmittance = cm_lightTransmittance(texturePosition);
  vec3 light = vec3(0.0);
  for (int i = 0; i < CM_LIGHT_COUNT; ++i)
  {
    light += cm_lightColors[i].rgb * transmittance[i];
  }
  return vec3(cm_ambient) + (1.0 - cm_ambient) * light;
}
