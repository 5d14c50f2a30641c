// Emission/absorption in VTK's volume mapper (the shading-init tag): VTK has set up the ray
// (entry at the box or the near plane, g_rayTermination at the opaque depth); we march it
// whole with the shared marcher and leave VTK's own loop before it starts.
{
  vec3 cm_entry = g_dataPos - g_rayJitter;
  vec3 cm_dir = g_dirStep;
  // Where the near plane cuts the box, VTK clips its box 0.001 (far - near) beyond the near
  // plane, which would leave that slice of the medium out: the ray starts where it meets the
  // near plane or enters the box, whichever comes last (on the box's face that is VTK's
  // entry itself).
  vec4 cm_near = ip_inverseTextureDataAdjusted * in_inverseVolumeMatrix[0]
    * in_inverseModelViewMatrix * in_inverseProjectionMatrix
    * WindowToNDC(gl_FragCoord.x, gl_FragCoord.y, gl_DepthRange.near);
  float cm_nearStart = dot(cm_near.xyz / cm_near.w - cm_entry, cm_dir) / dot(cm_dir, cm_dir);
  vec2 cm_box = cm_slab(cm_entry, cm_dir, in_texMin[0], in_texMax[0]);
  cm_entry += cm_dir * min(0.0, max(cm_nearStart, cm_box.x));
  float cm_boxExit = cm_slab(cm_entry, cm_dir, in_texMin[0], in_texMax[0]).y;
  float cm_depthExit = dot(g_rayTermination - cm_entry, cm_dir) / dot(cm_dir, cm_dir);
  vec3 cm_exit = cm_entry + cm_dir * max(0.0, min(cm_boxExit, cm_depthExit));
  float cm_worldLength = length(mat3(cm_worldFromTexture) * (cm_exit - cm_entry));
  g_fragColor = cm_march(cm_entry, cm_exit, cm_worldLength);
  g_exit = true;
}
