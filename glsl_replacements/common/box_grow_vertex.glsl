// Box actors (vertex stage, right after VTK's position): the corner drawn grown by its
// margin, so pixels whose rays graze the exact box are covered and decided by the shader
// (which cuts each ray to the exact box), not by rasterisation.
gl_Position = MCDCMatrix * vec4(vertexMC.xyz + cm_grow, 1.0);
