// The 2x2 bilateral filter of 000 section 3.2: the four texels bilinear sampling would use,
// each weighted by bilinear weight * max(1 - k_z |z_pixel - z_cube| / texel, 0), where z is
// the view distance at which the ray stops (opaque depth or the box). Where no texel shares
// this pixel's depth (a thin edge), the one with the closest depth is used.
vec4 cm_cubeLookup(vec3 texturePosition, float stopDistance)
{
  vec2 uv;
  int face = cm_faceOf(texturePosition, uv);
  vec2 tileOrigin = vec2(float(face % 3), float(face / 3)) * cm_faceSize;
  vec2 atlasSize = vec2(3.0, 2.0) * cm_faceSize;
  vec2 position = uv * cm_faceSize - 0.5;
  vec2 base = floor(position);
  vec2 f = position - base;
  vec4 sum = vec4(0.0);
  float total = 0.0;
  vec4 closest = vec4(0.0);
  float closestGap = 1e30;
  for (int j = 0; j < 2; ++j)
  {
    for (int i = 0; i < 2; ++i)
    {
      vec2 texel = clamp(base + vec2(i, j), vec2(0.0), vec2(cm_faceSize - 1.0));
      vec2 coord = (tileOrigin + texel + 0.5) / atlasSize;
      vec4 color = texture(cm_cubeColor, coord);
      float gap = abs(texture(cm_cubeDepth, coord).r - stopDistance) / cm_texelWorld;
      float weight = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y)
        * max(1.0 - cm_occlusionSharpness * gap, 0.0);
      sum += weight * color;
      total += weight;
      if (gap < closestGap)
      {
        closestGap = gap;
        closest = color;
      }
    }
  }
  return total > 1e-6 ? sum / total : closest;
}
