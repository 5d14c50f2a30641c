// Translucent surfaces (opacity below 1, traversal 'index'): the domain box drawn in the
// translucent pass once every opaque prop has written its depth. Each pixel's ray composites,
// front to back, every crossing of the surface up to the frame's opaque depth, each lit as
// the opaque surface is and covering cm_opacity of what lies behind: what PyVista draws for
// contour(...) + add_mesh(opacity=...) under depth peeling with enough peels. Straight alpha
// out, blended by the translucent pass: out = rgb a + (1 - a) dst.
uniform sampler2D cm_sceneDepth;   // opaque depth of this frame, over the viewport
uniform float cm_opacity;          // each crossing's opacity
