// Emission/absorption in VTK's volume mapper (the shading-init tag): VTK has set up the ray
// (entry at the box or the near plane, g_rayTermination at the opaque depth); we march it
// whole with the shared marcher and leave VTK's own loop before it starts.
{
  vec3 cm_entry = g_dataPos - g_rayJitter;
  vec3 cm_dir = g_dirStep;
  vec3 cm_safeDir = mix(cm_dir, vec3(1.0), lessThan(abs(cm_dir), vec3(1e-30)));
  vec3 cm_leave = max((in_texMax[0] - cm_entry) / cm_safeDir,
                      (in_texMin[0] - cm_entry) / cm_safeDir);
  cm_leave = mix(cm_leave, vec3(1e30), lessThan(abs(cm_dir), vec3(1e-30)));
  float cm_boxExit = min(cm_leave.x, min(cm_leave.y, cm_leave.z));
  float cm_depthExit = dot(g_rayTermination - cm_entry, cm_dir) / dot(cm_dir, cm_dir);
  vec3 cm_exit = cm_entry + cm_dir * max(0.0, min(cm_boxExit, cm_depthExit));
  float cm_worldLength = length(mat3(cm_worldFromTexture) * (cm_exit - cm_entry));
  g_fragColor = cm_march(cm_entry, cm_exit, cm_worldLength);
  g_exit = true;
}
