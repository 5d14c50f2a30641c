// Depth-aware upsampling of the reduced-resolution pass: declarations.
uniform vec3 cm_dims;                 // texels (points) of the volume along x, y, z
uniform sampler2D cm_lowColor;        // premultiplied rgba at 1/k resolution
uniform sampler2D cm_lowDepth;        // view z where each low-resolution ray stopped
uniform vec2 cm_lowSize;              // texels of the low-resolution targets
uniform float cm_depthSharpness;      // weight 0 once depths differ by 1/sharpness (relative)
uniform sampler2D cm_sceneColor;      // the scene drawn so far, over the viewport

// Joint bilateral 2x2 filter: bilinear weights times depth similarity to this pixel; where
// no neighbour shares its depth (a thin edge), the one with the closest depth.
vec4 cm_upsample(vec2 pixel, float viewZ)
{
  vec2 position = pixel * cm_lowSize - 0.5;
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
      vec2 texel = clamp(base + vec2(i, j), vec2(0.0), cm_lowSize - 1.0);
      vec2 coord = (texel + 0.5) / cm_lowSize;
      vec4 color = texture(cm_lowColor, coord);
      float gap = abs(texture(cm_lowDepth, coord).r - viewZ) / max(abs(viewZ), 1e-20);
      float weight = (i == 1 ? f.x : 1.0 - f.x) * (j == 1 ? f.y : 1.0 - f.y)
        * max(1.0 - cm_depthSharpness * gap, 0.0);
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
