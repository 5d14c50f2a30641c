// Emission/absorption in VTK's volume mapper (the shading-init tag): VTK has set up the ray
// (entry at the box or the near plane, g_rayTermination at the opaque depth); we march it
// whole with the shared marcher and leave VTK's own loop before it starts.
{
  vec3 cm_entry = g_dataPos - g_rayJitter;
  vec3 cm_dir = g_dirStep;
  float cm_boxExit = cm_slab(cm_entry, cm_dir, in_texMin[0], in_texMax[0]).y;
  float cm_depthExit = dot(g_rayTermination - cm_entry, cm_dir) / dot(cm_dir, cm_dir);
  vec3 cm_exit = cm_entry + cm_dir * max(0.0, min(cm_boxExit, cm_depthExit));
  float cm_worldLength = length(mat3(cm_worldFromTexture) * (cm_exit - cm_entry));
  g_fragColor = cm_march(cm_entry, cm_exit, cm_worldLength);
  g_exit = true;
}
