// requires: voxel_declarations
// Translucent materials of a material grid: the box's second actor, drawn in the translucent
// pass once every opaque prop (the grid's own opaque materials included) has written its
// depth. Each material is a closed translucent surface, as PyVista draws one
// threshold(...) + add_mesh(opacity=...) per label: the ray runs voxel by voxel from the box
// or the near plane to the frame's opaque depth, and where the label changes, the face of
// the material it leaves and then of the one it enters (each if translucent) is composited
// front to back; an opaque material or the opaque depth ends it (what lies there is already
// drawn). Straight-alpha out, blended by the translucent pass: out = rgb a + (1 - a) dst.
// These are the declarations; voxel_layers is the fragment's body.
uniform sampler2D cm_sceneDepth;     // opaque depth of this frame, over the viewport

// The material of a voxel as the layers see it: 0 empty or hidden, -1 opaque, else the
// translucent material.
int cm_layerMaterial(ivec3 voxel)
{
  int material = cm_visibleMaterial(voxel);
  if (material == 0)
  {
    return 0;
  }
  return cm_paletteEntry(material).a < 1.0 ? material : -1;
}

// One translucent face of `material` (entered through `face`, or its side facing the eye)
// at view point `hitView`, composited under what the ray holds (premultiplied).
void cm_addLayer(inout vec4 held, int material, int face, vec3 hitView, vec3 towardEye)
{
  vec4 rgba = cm_paletteEntry(material);
  vec3 color = rgba.rgb;
#ifdef CM_LIGHTING
  color = cm_shadeVoxel(color, face, hitView, towardEye);
#endif
  held += (1.0 - held.a) * rgba.a * vec4(clamp(color, 0.0, 1.0), 1.0);
}

