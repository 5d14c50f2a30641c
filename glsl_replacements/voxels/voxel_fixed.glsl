// requires: voxel_declarations
// Fixed-step traversal of a material grid (the baseline, kept to show what it misses):
// samples every cm_voxelStep voxels along the ray's dominant axis, along a + d t (index
// space) from t = start to end; the first sample inside a drawn voxel is the hit (its face
// is the box entry's for the first voxel, else unknown: -1).
// Thin voxels and corners between samples are stepped over. Same signature as the DDA.
uniform float cm_voxelStep;   // step in voxels along the dominant axis

int cm_voxelTraverse(vec3 a, vec3 d, float start, float end, out ivec3 voxel, inout int face,
                     out float t)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 span = abs(d) * (end - start);
  float steps = max(max(span.x, max(span.y, span.z)) / cm_voxelStep, 1.0);
  voxel = ivec3(0);
  for (float s = 0.0; s < steps; s += 1.0)
  {
    t = mix(start, end, s / steps);
    voxel = clamp(ivec3(floor(a + d * t)), ivec3(0), dims - 1);
    int material = cm_visibleMaterial(voxel);
    if (material != 0)
    {
      return material;
    }
    face = -1;
  }
  t = end;
  return 0;
}
