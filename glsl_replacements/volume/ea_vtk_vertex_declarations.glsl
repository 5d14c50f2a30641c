// VTK's volume mapper, vertex stage: declarations. Its input grid spans index space (points
// at integer coordinates) and the actor's matrix places it; this matrix takes an index
// point straight to clip space.
uniform mat4 cm_clipFromIndex;
