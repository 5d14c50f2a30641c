// The 2x2 bilateral filter of 000 section 3.2: the four texels bilinear sampling would use,
// each weighted by bilinear weight * max(1 - k_z |z_pixel - z_cube| / texel, 0), where z is
// the view distance at which the ray stops (opaque depth or the face). Where the four depths
// all agree with the pixel's (no mesh edge near) the weights are the bilinear ones and one
// hardware bilinear fetch gives the colour. Where no texel shares
// the pixel's depth (a thin edge), the one with the closest depth is used.
vec4 cm_cubeLookup(vec3 texturePosition, float stopDistance)
{
  vec2 uv;
  int face = cm_faceOf(texturePosition, uv);
  vec2 origin = cm_tileOrigin(face) + 1.0;      // first texel of the face in the atlas
  vec2 atlasSize = cm_atlasSize();
  vec2 position = uv * cm_faceSize;              // texel-corner units within the face
  vec2 coord = (origin + position) / atlasSize;
  vec2 f = fract(position - 0.5);
  ivec2 base = ivec2(floor(origin + position - 0.5));
  // the 2x2 footprint in the order (0, 1), (1, 1), (1, 0), (0, 0)
  vec4 depths = vec4(texelFetch(cm_cubeDepth, base + ivec2(0, 1), 0).r,
                     texelFetch(cm_cubeDepth, base + ivec2(1, 1), 0).r,
                     texelFetch(cm_cubeDepth, base + ivec2(1, 0), 0).r,
                     texelFetch(cm_cubeDepth, base, 0).r);
  vec4 similar = max(1.0 - cm_occlusionSharpness * abs(depths - stopDistance) / cm_texelWorld,
                     0.0);
  if (all(greaterThanEqual(similar, vec4(1.0))))
  {
    return texture(cm_cubeColor, coord);
  }
  vec4 bilinear = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
  vec4 weights = bilinear * similar;
  vec4 c01 = texelFetch(cm_cubeColor, base + ivec2(0, 1), 0);
  vec4 c11 = texelFetch(cm_cubeColor, base + ivec2(1, 1), 0);
  vec4 c10 = texelFetch(cm_cubeColor, base + ivec2(1, 0), 0);
  vec4 c00 = texelFetch(cm_cubeColor, base, 0);
  float total = weights.x + weights.y + weights.z + weights.w;
  if (total > 1e-6)
  {
    return (weights.x * c01 + weights.y * c11 + weights.z * c10 + weights.w * c00) / total;
  }
  vec4 gaps = abs(depths - stopDistance);
  float closest = min(min(gaps.x, gaps.y), min(gaps.z, gaps.w));
  return closest == gaps.x ? c01 : (closest == gaps.y ? c11 : (closest == gaps.z ? c10 : c00));
}
