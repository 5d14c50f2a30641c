// Emission/absorption in VTK's volume mapper, per-ray setup (the shading-init tag).
// VTK steps g_dirStep (texture space) from the entry point plus one step; sample k stands
// for the segment [k, k + 1] steps from the entry, so the segments tile the ray exactly and
// the last one is cut at the exit (the nearer of the box and the opaque depth).
vec3 cm_entry = g_dataPos - g_rayJitter;
vec3 cm_dir = g_dirStep;
// Slab exit in units of steps; axes with no motion never limit the ray.
vec3 cm_safeDir = mix(cm_dir, vec3(1.0), lessThan(abs(cm_dir), vec3(1e-30)));
vec3 cm_exitAxis = max((in_texMax[0] - cm_entry) / cm_safeDir, (in_texMin[0] - cm_entry) / cm_safeDir);
cm_exitAxis = mix(cm_exitAxis, vec3(1e30), lessThan(abs(cm_dir), vec3(1e-30)));
float cm_raySteps = min(min(cm_exitAxis.x, cm_exitAxis.y), cm_exitAxis.z);
cm_raySteps = min(cm_raySteps, g_terminatePointMax + length(g_rayJitter) / g_lengthStep);
// World length of one step: the sample distance is in dataset units along the unit ray.
float cm_worldStep = in_sampleDistance *
  length((in_volumeMatrix[0] * vec4(computeRayDirection(), 0.0)).xyz);
