// Colour by a value at the hit (CM_COLOR_BY_CURVATURE: the mean curvature; CM_COLOR_VALUES:
// a second field on the same cells, read by the storage's cm_colorValue), through a
// 256-entry colormap over cm_colorRange, the entry nearest the value's place (as the CPU
// reference picks it).
uniform sampler2D cm_colormap;     // 256 x 1 RGB
uniform vec2 cm_colorRange;        // the values at the colormap's ends
#ifdef CM_COLOR_BY_CURVATURE
uniform mat3 cm_indexFromWorld;    // world vectors to cell units (the inverse placement)
#endif

vec3 cm_colorOf(float value)
{
  float place = clamp((value - cm_colorRange.x) / (cm_colorRange.y - cm_colorRange.x),
                      0.0, 1.0);
  return texelFetch(cm_colormap, ivec2(int(place * 255.0 + 0.5), 0), 0).rgb;
}

#ifdef CM_COLOR_BY_CURVATURE
// The mean curvature (per world unit) of the loaded cell's level set at local `u`:
// -(|g|^2 tr H - g.H.g) / (2 |g|^3), gradient and Hessian taken to world units.
float cm_meanCurvature(vec3 u)
{
  vec3 bu = cm_basis(u.x), bv = cm_basis(u.y), bw = cm_basis(u.z);
  vec3 du = cm_basisDerivative(u.x), dv = cm_basisDerivative(u.y);
  vec3 dw = cm_basisDerivative(u.z);
  vec3 second = vec3(2.0, -4.0, 2.0);
  vec3 g = vec3(cm_tensor(du, bv, bw), cm_tensor(bu, dv, bw), cm_tensor(bu, bv, dw));
  mat3 h;
  h[0][0] = cm_tensor(second, bv, bw);
  h[1][1] = cm_tensor(bu, second, bw);
  h[2][2] = cm_tensor(bu, bv, second);
  h[0][1] = h[1][0] = cm_tensor(du, dv, bw);
  h[0][2] = h[2][0] = cm_tensor(du, bv, dw);
  h[1][2] = h[2][1] = cm_tensor(bu, dv, dw);
  mat3 a = cm_indexFromWorld;
  vec3 gw = transpose(a) * g;
  mat3 hw = transpose(a) * h * a;
  float norm = max(length(gw), 1e-30);
  float trace = hw[0][0] + hw[1][1] + hw[2][2];
  return -(norm * norm * trace - dot(gw, hw * gw)) / (2.0 * norm * norm * norm);
}
#endif
