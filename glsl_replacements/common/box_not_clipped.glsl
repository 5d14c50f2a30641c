// In place of VTK's clipping of the box's fragments by the mapper's clipping planes: the
// box is not cut (its pixels' rays are, by the same planes: clip_planes.glsl).
