// A prop drawn at reduced resolution into colour and depth targets (gl/reduced_draw.py),
// shown at full size by a stand-in with the prop's geometry.
uniform vec4 cm_viewport;             // origin and size of the renderer, in pixels
uniform vec2 cm_reducedSize;          // the targets' texels drawn, across and up
uniform sampler2D cm_reducedColor;
uniform sampler2D cm_reducedDepth;
