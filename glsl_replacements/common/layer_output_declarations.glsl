// Translucent layers, whose fragment runs where VTK sets the fragment's depth: that depth
// (the first face's) is then the one VTK's depth peeling sorts and tests the fragment by,
// not the box's raster depth. Their colour waits here for layer_output.glsl.
vec4 cm_layerColor = vec4(0.0);
