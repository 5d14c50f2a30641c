// Emission/absorption marching, shared by every path that draws a volume this way.
// The caller provides   float cm_sampleScalar(vec3 texturePosition)   (a data value) and the
// declarations of ea_declarations (cm_transfer, cm_composite, cm_stopOpacity); with
// CM_LIGHTS, also   vec3 cm_lighting(vec3 texturePosition)   (light_sample), which scales
// the emitted colour by the light reaching the sample.
//
// Texel-spaced ("half-adaptive") sampling: one step spans cm_stepScale texels along the
// ray's dominant texture axis; steps are constant along a ray, each sample is read at the
// middle of its segment, the last segment is cut at the exit, and its opacity uses its real
// world length. With CM_SKIP_EMPTY, bricks whose data range maps to zero extinction are
// stepped over whole: a brick is read once, its exit found by a slab test.

uniform vec3 cm_dims;          // texels (points) along x, y, z
uniform float cm_stepScale;    // step length in texels along the dominant axis
uniform mat4 cm_worldFromTexture;  // texture coordinates (texel centres at points) to world

#ifdef CM_LIGHTS
vec3 cm_lighting(vec3 texturePosition);   // defined by light_sample
#endif

#ifndef CM_JOINT
// Emitted colour and extinction of the medium at a texture position, before lighting.
// (With CM_JOINT, joint_sample defines it for several overlapping volumes.)
vec4 cm_unlitEmission(vec3 texturePosition)
{
  return cm_transfer(cm_sampleScalar(texturePosition));
}
#endif

// The same, lit when lights exist.
vec4 cm_emission(vec3 texturePosition)
{
  vec4 emission = cm_unlitEmission(texturePosition);
#ifdef CM_LIGHTS
  emission.rgb *= cm_lighting(texturePosition);
#endif
  return emission;
}

#ifdef CM_SKIP_EMPTY
uniform sampler3D cm_brickExtinction;  // per brick: largest extinction its data can reach
uniform vec3 cm_brickCount;            // bricks along x, y, z
uniform float cm_brickSize;            // points per brick edge

// Distance in steps from t to where the ray leaves the brick containing it.
float cm_brickExitSteps(vec3 entry, vec3 stepVector, float t)
{
  vec3 voxel = (entry + stepVector * t) * cm_dims - 0.5;      // point index space
  vec3 brick = clamp(floor(voxel / cm_brickSize), vec3(0.0), cm_brickCount - 1.0);
  vec3 lower = brick * cm_brickSize;
  return cm_slab(entry * cm_dims - 0.5, stepVector * cm_dims, lower, lower + cm_brickSize).y;
}

bool cm_brickIsEmpty(vec3 position)
{
  vec3 voxel = position * cm_dims - 0.5;
  vec3 brick = clamp(floor(voxel / cm_brickSize), vec3(0.0), cm_brickCount - 1.0);
  return texture(cm_brickExtinction, (brick + 0.5) / cm_brickCount).r <= 0.0;
}
#endif

// March from entry to exit (texture coordinates) over worldLength world units and return
// premultiplied rgba (rgb emitted colour, a opacity).
vec4 cm_march(vec3 entry, vec3 exit, float worldLength)
{
  vec4 rgba = vec4(0.0);
  vec3 span = exit - entry;
  vec3 texels = abs(span) * cm_dims;
  float dominant = max(texels.x, max(texels.y, texels.z));
  if (!(worldLength > 0.0) || !(dominant > 0.0))
  {
    return rgba;
  }
  float steps = max(dominant / cm_stepScale, 1e-6);   // fractional number of steps
  vec3 stepVector = span / steps;
  float worldStep = worldLength / steps;
  float t = 0.0;
  // Any number of steps: the inner loop has a fixed bound, the outer one repeats it until
  // the ray's end (steps is finite, so this ends; a NaN fails the test and ends at once).
  while (t < steps)
  {
    for (int i = 0; i < CM_STEPS_PER_LOOP; ++i)
    {
      if (t >= steps)
      {
        break;
      }
#ifdef CM_SKIP_EMPTY
      if (cm_brickIsEmpty(entry + stepVector * (t + 0.5 * min(1.0, steps - t))))
      {
        // Resume on the same step grid, at the step that holds the brick's exit.
        t = max(t + 1.0, floor(cm_brickExitSteps(entry, stepVector, t) + 1e-4));
        continue;
      }
#endif
      float fraction = min(1.0, steps - t);
      vec3 middle = entry + stepVector * (t + 0.5 * fraction);
      cm_composite(rgba, cm_emission(middle), worldStep * fraction);
      if (rgba.a > cm_stopOpacity)
      {
        return rgba;
      }
      t += 1.0;
    }
  }
  return rgba;
}
