// requires: layer_output_declarations
// After VTK's lighting, which it replaces: the colour the layers' fragment found.
fragOutput0 = cm_layerColor;
