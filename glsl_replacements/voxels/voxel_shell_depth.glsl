// The brick shell's depth pass (gl/face_depth.py; after VTK's lighting, which it
// replaces): this fragment's view depth, where the pixel's ray meets the shell; the depth
// test keeps the nearest face.
fragOutput0 = vec4(cm_proxyDepth, 0.0, 0.0, 1.0);
