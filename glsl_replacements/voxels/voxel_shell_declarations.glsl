// The brick shell's depth pass (fragment stage): the face's view depth from the vertex
// stage (voxel_proxy_vertex.glsl).
in float cm_proxyDepth;
