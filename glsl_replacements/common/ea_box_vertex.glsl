// Volume box actors (vertex stage, after VTK's position): keep back faces that lie beyond
// the far clipping plane, pulled onto it, so the far plane cuts the volume's rays instead
// of dropping whole triangles of the box.
gl_Position.z = min(gl_Position.z, gl_Position.w * 0.9999999);
