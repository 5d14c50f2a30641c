// Emission/absorption marching, shared by every path that draws a volume this way.
// The caller provides   float cm_sampleScalar(vec3 texturePosition)   (a data value; with
// CM_DIRECT_COLOR also   vec4 cm_sampleDirect(vec3)   (colour, value)), the
// declarations of ea_declarations (cm_transfer, cm_composite, cm_stopOpacity) and a blend
// mode (blend_composite, blend_maximum ...: cm_blendStart, cm_blend, cm_blendResult); with
// CM_LIGHTS, also   vec3 cm_lighting(vec3 texturePosition)   (light_sample), which scales
// the emitted colour by the light reaching the sample.
//
// Texel-spaced ("half-adaptive") sampling: one step spans cm_stepScale texels along the
// ray's dominant texture axis; steps are constant along a ray, each sample is read at the
// middle of its segment, the last segment is cut at the exit, and its opacity uses its real
// length in data units (cm_mediumLength). With CM_SKIP_EMPTY, bricks whose data range maps
// to zero extinction are stepped over whole: a brick is read once, its exit found by a
// slab test.
//
// Any number of steps: a ray (or, in a joint group, each piece of it) is marched in blocks
// of CM_STEP_BLOCK steps, at most CM_STEP_BLOCKS blocks; both loops have constant bounds, so
// no loop can run forever, and their product (2^24) is more than add_volume lets a setting
// ask for (it refuses step_scale or max_samples that would need more, saying why). Needs
// cm_slab (slab.glsl).
//
// With CM_JOINT (overlapping volumes marched as one medium), the ray is cut where it enters
// or leaves a member's box, and each piece is stepped cm_stepScale texels of the finest grid
// over it (the group's virtual grid or a member's own); pieces no member covers hold nothing
// and are skipped. A tiny member inside a huge one is stepped at its own spacing, the rest of
// the ray at the huge one's.

uniform vec3 cm_dims;          // texels (points) along x, y, z
uniform float cm_stepScale;    // step length in texels along the dominant axis
uniform mat4 cm_worldFromTexture;  // texture coordinates (texel centres at points) to world

#ifdef CM_LIGHTS
vec3 cm_lighting(vec3 texturePosition);   // defined by light_sample
#endif
#ifdef CM_SHADE
vec3 cm_shade(vec3 texturePosition, vec3 color);   // defined by gradient_shading
vec3 cm_rayWorld;              // the ray's unit direction in the world, for the shading
#endif

#ifndef CM_JOINT
// Emitted colour and extinction of the medium at a texture position, before lighting.
// (With CM_JOINT, joint_sample defines it for several overlapping volumes.) A
// direct-colour volume emits its own colour with the extinction of its alpha.
vec4 cm_unlitEmission(vec3 texturePosition)
{
#ifdef CM_DIRECT_COLOR
  vec4 direct = cm_sampleDirect(texturePosition);
  return vec4(direct.rgb, cm_transfer(direct.a).a);
#else
  return cm_transfer(cm_sampleScalar(texturePosition));
#endif
}
#endif

// The same, lit when lights exist.
vec4 cm_emission(vec3 texturePosition)
{
  vec4 emission = cm_unlitEmission(texturePosition);
#ifdef CM_LIGHTS
  emission.rgb *= cm_lighting(texturePosition);
#endif
#ifdef CM_SHADE
  if (emission.a > 0.0)
  {
    emission.rgb = cm_shade(texturePosition, emission.rgb);
  }
#endif
  return emission;
}

#if defined(CM_SKIP_EMPTY) && !defined(CM_PAGED_LEVELS)   // paged: paged_sample.glsl's
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

// Texels of a grid of `dims` points that a span (texture coordinates) crosses along its
// dominant axis.
float cm_dominantTexels(vec3 span, vec3 dims)
{
  vec3 texels = abs(span) * dims;
  return max(texels.x, max(texels.y, texels.z));
}

// Blend the piece from a to b (texture coordinates, mediumLength data units long:
// cm_mediumLength) into the ray's state in `steps` equal steps (fractional: the last one
// is cut at b). False once the blend mode stops the ray (composite: opaque enough).
bool cm_marchPiece(inout vec4 rgba, vec3 a, vec3 b, float mediumLength, float steps)
{
  vec3 stepVector = (b - a) / steps;
  float mediumStep = mediumLength / steps;
  float t = 0.0;
  for (int block = 0; block < CM_STEP_BLOCKS; ++block)
  {
    for (int i = 0; i < CM_STEP_BLOCK; ++i)
    {
      if (t >= steps)
      {
        return true;
      }
#ifdef CM_SKIP_EMPTY
      if (cm_brickIsEmpty(a + stepVector * (t + 0.5 * min(1.0, steps - t))))
      {
        // Resume on the same step grid, at the step that holds the brick's exit.
        t = max(t + 1.0, floor(cm_brickExitSteps(a, stepVector, t) + 1e-4));
        continue;
      }
#endif
      float fraction = min(1.0, steps - t);
      vec3 middle = a + stepVector * (t + 0.5 * fraction);
      if (!cm_blend(rgba, middle, mediumStep * fraction))
      {
        return false;
      }
      t += 1.0;
    }
  }
  return true;
}

// Blend the span f0..f1 of the ray from entry to exit, stepped cm_stepScale of the `texels`
// the whole ray crosses (a piece of a joint group's ray, or of a multiscale volume's).
bool cm_marchSpan(inout vec4 rgba, vec3 entry, vec3 exit, float mediumLength, float f0,
                  float f1, float texels)
{
  return cm_marchPiece(rgba, mix(entry, exit, f0), mix(entry, exit, f1),
                       mediumLength * (f1 - f0), max(texels * (f1 - f0) / cm_stepScale, 1e-6));
}

#ifdef CM_JOINT
// A joint group's ray, piece by piece between the members' box boundaries (joint_sample's
// cm_memberSpans gives where each member's box starts and ends along the ray).
void cm_marchJoint(inout vec4 rgba, vec3 entry, vec3 exit, float mediumLength,
                   float groupTexels)
{
  vec4 enter, leave, texels;
  cm_memberSpans(entry, exit, enter, leave, texels);
  float f0 = 0.0;
  for (int piece = 0; piece < 2 * CM_VOLUME_COUNT + 1; ++piece)
  {
    // The next box boundary after f0 (or the ray's end).
    vec4 nextEnter = mix(vec4(1.0), enter, greaterThan(enter, vec4(f0)));
    vec4 nextLeave = mix(vec4(1.0), leave, greaterThan(leave, vec4(f0)));
    vec4 next = min(min(nextEnter, nextLeave), vec4(1.0));
    float f1 = min(min(next.x, next.y), min(next.z, next.w));
    float middle = 0.5 * (f0 + f1);
    vec4 covers = step(enter, vec4(middle)) * step(vec4(middle), leave);
    if (f1 > f0 && dot(covers, vec4(1.0)) > 0.0)
    {
      vec4 own = covers * texels;
      float finest = max(groupTexels, max(max(own.x, own.y), max(own.z, own.w)));
      if (!cm_marchSpan(rgba, entry, exit, mediumLength, f0, f1, finest))
      {
        return;
      }
    }
    f0 = f1;
    if (f0 >= 1.0)
    {
      return;
    }
  }
}
#endif

#ifdef CM_PAGED_LEVELS
// A multiscale volume's ray (paged_sample), in pieces along which one level is chosen, each
// stepped cm_stepScale points of that level: far pieces read coarse levels in few steps.
void cm_marchPaged(inout vec4 rgba, vec3 entry, vec3 exit, float mediumLength)
{
  float f0 = 0.0;
  for (int piece = 0; piece < 2 * CM_PAGED_LEVELS + 1; ++piece)
  {
    float f1 = cm_pagedLevelEnd(entry, exit, f0);
    int level = cm_pagedLevelAt(mix(entry, exit, 0.5 * (f0 + f1)));
    if (!cm_marchSpan(rgba, entry, exit, mediumLength, f0, f1,
                      cm_pagedTexels(exit - entry, level)) || f1 >= 1.0)
    {
      return;
    }
    f0 = f1;
  }
}
#endif

// March from entry to exit (texture coordinates), mediumLength data units apart, and return
// premultiplied rgba (rgb emitted colour, a opacity).
vec4 cm_march(vec3 entry, vec3 exit, float mediumLength)
{
  vec4 rgba = cm_blendStart();
#ifdef CM_SHADE
  cm_rayWorld = normalize(mat3(cm_worldFromTexture) * (exit - entry));
#endif
  float dominant = cm_dominantTexels(exit - entry, cm_dims);
  if (!(mediumLength > 0.0) || !(dominant > 0.0))
  {
    return vec4(0.0);
  }
#ifdef CM_JOINT
  cm_marchJoint(rgba, entry, exit, mediumLength, dominant);
#elif defined(CM_PAGED_LEVELS)
  cm_marchPaged(rgba, entry, exit, mediumLength);
#else
  cm_marchPiece(rgba, entry, exit, mediumLength, max(dominant / cm_stepScale, 1e-6));
#endif
  return cm_blendResult(rgba);
}
