// Emission/absorption in VTK's volume mapper, per sample (the shading-impl tag).
// Sample k (g_currentT) stands for the segment [k, k + 1] steps from the entry and is
// read at its midpoint. VTK leaves its loop as soon as the *next* position is outside the
// box, so the sample whose successor would cross the exit also integrates the tail
// [k + 1, exit] and ends the ray: the segments tile the ray exactly.
{
  float cm_fraction = clamp(cm_raySteps - g_currentT, 0.0, 1.0);
  if (cm_fraction <= 0.0)
  {
    g_exit = true;
  }
  else
  {
    vec3 cm_mid = g_dataPos - (1.0 - 0.5 * cm_fraction) * g_dirStep;
    cm_composite(g_fragColor, cm_transfer(cm_volumeScalar(cm_mid)), cm_worldStep * cm_fraction);
    float cm_tail = cm_raySteps - g_currentT - 1.0;
    if (cm_tail > 0.0 && cm_tail <= 1.0)
    {
      vec3 cm_tailMid = g_dataPos + 0.5 * cm_tail * g_dirStep;
      cm_composite(g_fragColor, cm_transfer(cm_volumeScalar(cm_tailMid)), cm_worldStep * cm_tail);
      g_exit = true;
    }
    if (g_fragColor.a > cm_stopOpacity)
    {
      g_exit = true;
    }
  }
}
