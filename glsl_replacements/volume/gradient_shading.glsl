// Gradient shading (add_volume(shade=True)), as VTK's GPU volume mapper shades a sample:
// the normal is the data's central-difference gradient (one step of 1/(points - 1) in
// texture coordinates per axis, over the spacing), oriented up the gradient; each light
// adds diffuse and specular terms (two-sided lighting as the renderer says), the colour
// is clamped to [0, 1] and the opacity is left as it is. Two paths, as VTK's: one
// headlight of intensity 1 lights the sample from the eye; any other set of lights uses
// VTK's normal transform (cm_shadeNormal) and per-light directions of travel, in world
// coordinates here (VTK works in view coordinates; the dot products are the same).
uniform vec3 cm_spacing;          // world length of one point step along each axis
uniform mat3 cm_shadeNormal;      // gradient to the normal VTK shades with (world)
uniform float cm_shadeLights[CM_SHADE_LIGHTS * 9];  // per light: travel, diffuse, specular
uniform vec3 cm_shadeAmbient;     // the lights' ambient colours times intensities, summed
uniform vec4 cm_shadeMaterial;    // ambient, diffuse, specular, specular power
uniform int cm_shadeLightCount;   // switched-on lights (<= CM_SHADE_LIGHTS)
uniform int cm_shadeHeadlight;    // 1: VTK's single-headlight path
uniform int cm_twoSided;          // the renderer's two-sided lighting
// (cm_rayWorld, the ray's unit direction in the world, is ea_march's; after it, as are
// cm_dims and cm_sampleScalar.)

vec3 cm_shadeVector(int light, int part)
{
  int at = light * 9 + part * 3;
  return vec3(cm_shadeLights[at], cm_shadeLights[at + 1], cm_shadeLights[at + 2]);
}

vec3 cm_gradient(vec3 p)
{
  vec3 step = 1.0 / max(cm_dims - 1.0, vec3(1.0));
  vec3 g = vec3(
    cm_sampleScalar(p + vec3(step.x, 0.0, 0.0)) - cm_sampleScalar(p - vec3(step.x, 0.0, 0.0)),
    cm_sampleScalar(p + vec3(0.0, step.y, 0.0)) - cm_sampleScalar(p - vec3(0.0, step.y, 0.0)),
    cm_sampleScalar(p + vec3(0.0, 0.0, step.z)) - cm_sampleScalar(p - vec3(0.0, 0.0, step.z)));
  return g / cm_spacing;
}

vec3 cm_shade(vec3 p, vec3 color)
{
  float ka = cm_shadeMaterial.x;
  float kd = cm_shadeMaterial.y;
  float ks = cm_shadeMaterial.z;
  float power = cm_shadeMaterial.w;
  vec3 g = cm_gradient(p);
  if (cm_shadeHeadlight == 1)
  {
    vec3 toEye = -cm_rayWorld;
    vec3 n = length(g) > 0.0 ? normalize(g) : vec3(0.0);
    float d = dot(n, cm_rayWorld);
    float rho = dot(normalize(2.0 * d * n + toEye), cm_rayWorld);
    if (cm_twoSided == 1)
    {
      d = abs(d);
    }
    vec3 shaded = ka * color;
    if (d > 0.0)
    {
      shaded += kd * d * cm_shadeVector(0, 1) * color
        + ks * pow(max(rho, 0.0), power) * cm_shadeVector(0, 2);
    }
    return clamp(shaded, 0.0, 1.0);
  }
  vec3 diffuse = vec3(0.0);
  vec3 specular = vec3(0.0);
  vec3 normal = cm_shadeNormal * g;
  if (length(normal) > 0.0)
  {
    vec3 n = normalize(normal);
    for (int i = 0; i < CM_SHADE_LIGHTS; ++i)
    {
      if (i >= cm_shadeLightCount)
      {
        break;
      }
      vec3 travel = cm_shadeVector(i, 0);
      float d = dot(n, travel);
      if (cm_twoSided == 1 && d < 0.0)
      {
        d = -d;
      }
      if (d > 0.0)
      {
        diffuse += d * cm_shadeVector(i, 1);
        float rho = dot(cm_rayWorld, normalize(2.0 * d * n - travel));
        if (rho > 0.0)
        {
          specular += pow(rho, power) * cm_shadeVector(i, 2);
        }
      }
    }
  }
  return clamp(ka * cm_shadeAmbient + kd * diffuse * color + ks * specular, 0.0, 1.0);
}
