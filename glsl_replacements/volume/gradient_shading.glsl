// Gradient shading (add_volume(shade=True)), as VTK's GPU volume mapper shades a sample:
// the normal is the data's central-difference gradient (one step of 1/(points - 1) in
// texture coordinates per axis, over the spacing), oriented up the gradient; each light
// adds diffuse and specular terms (two-sided lighting as the renderer says), the colour
// is clamped to [0, 1] and the opacity is left as it is. Two paths, as VTK's: one
// headlight of intensity 1 lights the sample from the eye; any other set of lights uses
// VTK's normal transform (cm_shadeNormal) and per-light directions of travel, in world
// coordinates here (VTK works in view coordinates; the dot products are the same). A
// positional light's travel runs from it to the sample, scaled by VTK's attenuation
// 1 / (a + b d + c d^2) and, as a spot (cone angle up to 90 degrees), by the cone's
// pow(cos, exponent), nothing outside it; its highlight is two-sided too, as VTK's.
uniform vec3 cm_spacing;          // world length of one point step along each axis
uniform mat3 cm_shadeNormal;      // gradient to the normal VTK shades with (world)
// Per light (CM_SHADE_FLOATS each): travel (a spot's axis), diffuse, specular, position
// (world), attenuation, cone angle (degrees), exponent, positional (1) or not (0).
uniform float cm_shadeLights[CM_SHADE_LIGHTS * CM_SHADE_FLOATS];
uniform vec3 cm_shadeAmbient;     // the lights' ambient colours times intensities, summed
uniform vec4 cm_shadeMaterial;    // ambient, diffuse, specular, specular power
uniform int cm_shadeLightCount;   // switched-on lights (<= CM_SHADE_LIGHTS)
uniform int cm_shadeHeadlight;    // 1: VTK's single-headlight path
uniform int cm_twoSided;          // the renderer's two-sided lighting
// (cm_rayWorld, the ray's unit direction in the world, is ea_march's; after it, as are
// cm_dims and cm_sampleScalar.)

vec3 cm_shadeVector(int light, int part)
{
  int at = light * CM_SHADE_FLOATS + part * 3;
  return vec3(cm_shadeLights[at], cm_shadeLights[at + 1], cm_shadeLights[at + 2]);
}

float cm_shadeNumber(int light, int index)
{
  return cm_shadeLights[light * CM_SHADE_FLOATS + index];
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
      float attenuation = 1.0;
      bool positional = cm_shadeNumber(i, 17) > 0.5;
      if (positional)
      {
        vec3 away = (cm_worldFromTexture * vec4(p, 1.0)).xyz - cm_shadeVector(i, 3);
        float distance = length(away);
        vec3 axis = travel;
        travel = distance > 0.0 ? away / distance : axis;
        vec3 falloff = cm_shadeVector(i, 4);
        attenuation = 1.0 / (falloff.x + falloff.y * distance
                             + falloff.z * distance * distance);
        float cone = cm_shadeNumber(i, 15);
        if (cone <= 90.0)
        {
          float along = dot(travel, axis);
          attenuation = along >= cos(radians(cone))
                        ? attenuation * pow(along, cm_shadeNumber(i, 16)) : 0.0;
        }
      }
      float d = dot(n, travel);
      if (cm_twoSided == 1 && d < 0.0)
      {
        d = -d;
      }
      if (d > 0.0)
      {
        diffuse += max(0.0, attenuation * d) * cm_shadeVector(i, 1);
        float rho = dot(cm_rayWorld, normalize(2.0 * d * n - travel));
        if (positional && cm_twoSided == 1 && rho < 0.0)
        {
          rho = -rho;
        }
        if (rho > 0.0)
        {
          specular += attenuation * pow(rho, power) * cm_shadeVector(i, 2);
        }
      }
    }
  }
  return clamp(ka * cm_shadeAmbient + kd * diffuse * color + ks * specular, 0.0, 1.0);
}
