// Emission/absorption in VTK's volume mapper, per sample (the shading-impl tag).
{
  float cm_fraction = clamp(cm_raySteps - g_currentT, 0.0, 1.0);
  if (cm_fraction <= 0.0)
  {
    g_exit = true;
  }
  else
  {
    float cm_scalar = texture(in_volume[0], g_dataPos).r * in_volume_scale[0].r
      + in_volume_bias[0].r;
    cm_composite(g_fragColor, cm_transfer(cm_scalar), cm_worldStep * cm_fraction);
    if (g_fragColor.a > cm_stopOpacity)
    {
      g_exit = true;
    }
  }
}
