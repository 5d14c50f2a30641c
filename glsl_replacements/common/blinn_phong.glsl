// Lighting of an opaque hit by the scene's lights (gl/lights.py), terms as VTK lights a mesh:
// colour * (ambient + diffuse * sum light * max(n.l, 0))
// + specular * sum light * max(n.h, 0)^power (the highlight with CM_SPECULAR). Lights in view
// space, up to 8: column i of cm_lightVectors0/1 is the direction toward a directional light
// (w = 0) or a point light's position (w = 1); of cm_lightColors0/1 its colour times
// intensity.
uniform int cm_lightCount;
uniform mat4 cm_lightVectors0;
uniform mat4 cm_lightVectors1;
uniform mat4 cm_lightColors0;
uniform mat4 cm_lightColors1;
uniform mat3 cm_normalFromIndex;   // index-space normals to view space (inverse transpose)
uniform float cm_ambient;
uniform float cm_diffuse;
uniform float cm_specular;
uniform float cm_specularPower;

vec3 cm_shade(vec3 color, vec3 normal, vec3 pointView, vec3 towardEye)
{
  vec3 diffuse = vec3(0.0);
  vec3 shine = vec3(0.0);
  for (int i = 0; i < cm_lightCount; ++i)
  {
    vec4 light = i < 4 ? cm_lightVectors0[i] : cm_lightVectors1[i - 4];
    vec3 radiance = (i < 4 ? cm_lightColors0[i] : cm_lightColors1[i - 4]).rgb;
    vec3 toward = normalize(light.w > 0.5 ? light.xyz - pointView : light.xyz);
    diffuse += max(dot(normal, toward), 0.0) * radiance;
#ifdef CM_SPECULAR
    vec3 halfway = normalize(toward + towardEye);
    shine += pow(max(dot(normal, halfway), 0.0), cm_specularPower) * radiance;
#endif
  }
  return clamp(color * (cm_ambient + cm_diffuse * diffuse) + cm_specular * shine, 0.0, 1.0);
}
