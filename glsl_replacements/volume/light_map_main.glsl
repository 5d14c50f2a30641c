// requires: ea_declarations, slab
// Light-map pass: for each point of an L^3 grid over the volume, the
// transmittance toward each light, marched through the same transfer function (rgba =
// lights 0..3), through one volume or a joint group (whose members shade each other).
// Output: L slices of L x L stacked along y. Runs only when a light, the volume's placement
// or its data change.
uniform float cm_lightMapSize;   // L
uniform mat4 cm_lightVectors;    // column i: light i in texture coordinates; w = 0: direction
                                 // toward the light, w = 1: the light's position
uniform float cm_lightStepScale; // step in texels along the dominant axis

float cm_transmittanceToward(vec3 start, vec4 light)
{
  vec3 span = light.w > 0.5 ? light.xyz - start : light.xyz;
  float stop = max(0.0, cm_slab(start, span, 0.5 / cm_dims, 1.0 - 0.5 / cm_dims).y);
  if (light.w > 0.5)
  {
    stop = min(stop, 1.0);   // a point light inside the volume: march up to it
  }
  vec3 path = span * stop;
  vec3 texels = abs(path) * cm_dims;
  float dominant = max(texels.x, max(texels.y, texels.z));
  float mediumLength = cm_mediumLength(path);
  if (!(dominant > 0.0) || !(mediumLength > 0.0))
  {
    return 1.0;
  }
  float steps = max(dominant / cm_lightStepScale, 1e-6);
  float opticalDepth = 0.0;
  float t = 0.0;
  // Any number of steps, in bounded blocks (as ea_march's cm_marchPiece).
  for (int block = 0; block < CM_STEP_BLOCKS; ++block)
  {
    for (int i = 0; i < CM_STEP_BLOCK; ++i)
    {
      if (t >= steps || opticalDepth > 30.0)
      {
        return exp(-opticalDepth);
      }
      float fraction = min(1.0, steps - t);
      vec3 middle = start + path * ((t + 0.5 * fraction) / steps);
#ifdef CM_CLIP_PLANES
      opticalDepth += cm_unlitEmission(middle).a * mediumLength / steps * fraction
                      * cm_clipKeeps(middle);   // a clipped medium casts no shadow
#else
      opticalDepth += cm_unlitEmission(middle).a * mediumLength / steps * fraction;
#endif
      t += 1.0;
    }
  }
  return exp(-opticalDepth);
}

void main()
{
  float size = cm_lightMapSize;
  vec2 texel = floor(texCoord * vec2(size, size * size));
  vec3 grid = vec3(texel.x, mod(texel.y, size), floor(texel.y / size));
  vec3 start = (grid / (size - 1.0) * (cm_dims - 1.0) + 0.5) / cm_dims;
  vec4 result = vec4(1.0);
  for (int i = 0; i < CM_LIGHT_COUNT; ++i)
  {
    result[i] = cm_transmittanceToward(start, cm_lightVectors[i]);
  }
  gl_FragData[0] = result;
}
