// opacityThreshold of a UsdPreviewSurface (cut-outs such as leaves): after VTK's lighting,
// a fragment whose opacity is below the threshold is dropped, and one above it is opaque.
if (fragOutput0.a < CM_OPACITY_THRESHOLD) {
  discard;
}
fragOutput0.a = 1.0;
