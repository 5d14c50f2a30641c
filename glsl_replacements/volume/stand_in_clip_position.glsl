// The stand-in volume draws nothing: every corner of its box goes outside the clip volume,
// so no fragment is made (its mapper still gives the plotter bounds, planes and properties).
gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
