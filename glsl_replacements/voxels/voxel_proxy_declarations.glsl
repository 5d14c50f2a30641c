// Proxy faces of a material grid (vertex stage): each vertex's view depth, interpolated to
// the fragment (exactly, faces being flat), where the fragment's ray may start when the
// faces are the brick shell (models.voxels.brick_shell: it stands off every filled voxel).
uniform mat4 cm_projection;
out float cm_proxyDepth;
