// requires: cube_faces
// The 2x2 bilateral depth filter: the four texels bilinear sampling would use,
// each weighted by bilinear weight * max(1 - k_z |z_pixel - z_cube| / texel, 0), where z is
// the distance along the view axis at which the ray stops (opaque depth or the face).
// Written without branches: llvmpipe runs both sides of a divergent branch.

// Plain bilinear sampling of the cube map at a point of a face (a scene without opaque
// props: the shader is compiled without CM_OCCLUSION and never reads the depth).
vec4 cm_cubeBilinear(vec3 texturePosition)
{
  vec2 uv;
  int face = cm_faceOf(texturePosition, uv);
  return texture(cm_cubeColor, (cm_tileOrigin(face) + 1.0 + uv * cm_faceSize) / cm_atlasAllocated);
}

// The bilateral filter at a point of a face, for a pixel whose ray stops at stopDistance.
vec4 cm_cubeLookup(vec3 texturePosition, float stopDistance)
{
  vec2 uv;
  int face = cm_faceOf(texturePosition, uv);
  vec2 position = cm_tileOrigin(face) + 0.5 + uv * cm_faceSize;   // atlas texel units
  vec2 f = fract(position);
  ivec2 base = ivec2(floor(position));
  // the 2x2 footprint in the order (0, 1), (1, 1), (1, 0), (0, 0)
  vec4 depths = vec4(texelFetch(cm_cubeDepth, base + ivec2(0, 1), 0).r,
                     texelFetch(cm_cubeDepth, base + ivec2(1, 1), 0).r,
                     texelFetch(cm_cubeDepth, base + ivec2(1, 0), 0).r,
                     texelFetch(cm_cubeDepth, base, 0).r);
  vec4 gaps = abs(depths - stopDistance);
  vec4 weights = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y))
    * max(1.0 - cm_occlusionSharpness * gaps / cm_texelWorld, 0.0);
  float total = dot(weights, vec4(1.0));
  // Where no texel shares the pixel's depth, the closest one alone.
  float closest = min(min(gaps.x, gaps.y), min(gaps.z, gaps.w));
  vec4 only = vec4(equal(gaps, vec4(closest)));
  weights = total > 1e-6 ? weights / total : only / dot(only, vec4(1.0));
  return weights.x * texelFetch(cm_cubeColor, base + ivec2(0, 1), 0)
    + weights.y * texelFetch(cm_cubeColor, base + ivec2(1, 1), 0)
    + weights.z * texelFetch(cm_cubeColor, base + ivec2(1, 0), 0)
    + weights.w * texelFetch(cm_cubeColor, base, 0);
}
