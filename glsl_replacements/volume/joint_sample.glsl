// requires: ea_declarations, slab
// Several overlapping volumes marched as one medium (CM_JOINT, up to 4 members): a sample
// of the group's box adds the extinction of every member whose box of texel centres holds
// it, and emits their extinction-weighted mean colour, the model of the CPU reference.
// GLSL 1.50 cannot index sampler arrays, so each member has its own uniforms.
uniform sampler3D cm_member0;        // data values of member 0
uniform sampler2D cm_memberTable0;   // its transfer table (rgb, extinction)
uniform vec2 cm_memberClim0;         // its table's scalar range
uniform mat4 cm_memberFromGroup0;    // group texture coordinates to its own
uniform vec3 cm_memberDims0;         // its points along x, y, z
#if CM_VOLUME_COUNT > 1
uniform sampler3D cm_member1;        // data values of member 1
uniform sampler2D cm_memberTable1;   // its transfer table (rgb, extinction)
uniform vec2 cm_memberClim1;         // its table's scalar range
uniform mat4 cm_memberFromGroup1;    // group texture coordinates to its own
uniform vec3 cm_memberDims1;         // its points along x, y, z
#endif
#if CM_VOLUME_COUNT > 2
uniform sampler3D cm_member2;        // data values of member 2
uniform sampler2D cm_memberTable2;   // its transfer table (rgb, extinction)
uniform vec2 cm_memberClim2;         // its table's scalar range
uniform mat4 cm_memberFromGroup2;    // group texture coordinates to its own
uniform vec3 cm_memberDims2;         // its points along x, y, z
#endif
#if CM_VOLUME_COUNT > 3
uniform sampler3D cm_member3;        // data values of member 3
uniform sampler2D cm_memberTable3;   // its transfer table (rgb, extinction)
uniform vec2 cm_memberClim3;         // its table's scalar range
uniform mat4 cm_memberFromGroup3;    // group texture coordinates to its own
uniform vec3 cm_memberDims3;         // its points along x, y, z
#endif

// Bit i of CM_DIRECT_MEMBERS: member i is an RGBA volume (uint8 colours, the opacity's
// value in alpha), which emits its own colour with the extinction of its alpha.
#ifndef CM_DIRECT_MEMBERS
#define CM_DIRECT_MEMBERS 0
#endif

// A member's emission (rgb, extinction) at a group position: nothing outside its box of
// texel centres.
vec4 cm_memberEmission(sampler3D volume, sampler2D table, vec2 clim, mat4 fromGroup,
                       vec3 dims, vec3 groupPosition, int member)
{
  vec3 position = (fromGroup * vec4(groupPosition, 1.0)).xyz;
  vec3 lo = 0.5 / dims;
  if (any(lessThan(position, lo)) || any(greaterThan(position, 1.0 - lo)))
  {
    return vec4(0.0);
  }
  vec4 texel = texture(volume, position);
  if ((CM_DIRECT_MEMBERS & (1 << member)) != 0)
  {
    return vec4(texel.rgb, cm_transferLookup(table, clim, texel.a * 255.0).a);
  }
  return cm_transferLookup(table, clim, texel.r);
}

void cm_addMember(inout vec4 sum, sampler3D volume, sampler2D table, vec2 clim,
                  mat4 fromGroup, vec3 dims, vec3 groupPosition, int member)
{
  vec4 emission = cm_memberEmission(volume, table, clim, fromGroup, dims, groupPosition,
                                    member);
  sum.rgb += emission.a * emission.rgb;
  sum.a += emission.a;
}

#ifdef CM_CHANNELS_ADDITIVE
// Every member's own emission, one per column (unused columns: nothing), for channels
// that add their light (blend_channels_additive).
void cm_channelEmissions(vec3 texturePosition, out mat4 emissions)
{
  emissions = mat4(0.0);
  emissions[0] = cm_memberEmission(cm_member0, cm_memberTable0, cm_memberClim0,
                                   cm_memberFromGroup0, cm_memberDims0, texturePosition, 0);
#if CM_VOLUME_COUNT > 1
  emissions[1] = cm_memberEmission(cm_member1, cm_memberTable1, cm_memberClim1,
                                   cm_memberFromGroup1, cm_memberDims1, texturePosition, 1);
#endif
#if CM_VOLUME_COUNT > 2
  emissions[2] = cm_memberEmission(cm_member2, cm_memberTable2, cm_memberClim2,
                                   cm_memberFromGroup2, cm_memberDims2, texturePosition, 2);
#endif
#if CM_VOLUME_COUNT > 3
  emissions[3] = cm_memberEmission(cm_member3, cm_memberTable3, cm_memberClim3,
                                   cm_memberFromGroup3, cm_memberDims3, texturePosition, 3);
#endif
}
#endif

vec4 cm_unlitEmission(vec3 texturePosition)
{
  vec4 sum = vec4(0.0);
  cm_addMember(sum, cm_member0, cm_memberTable0, cm_memberClim0, cm_memberFromGroup0,
               cm_memberDims0, texturePosition, 0);
#if CM_VOLUME_COUNT > 1
  cm_addMember(sum, cm_member1, cm_memberTable1, cm_memberClim1, cm_memberFromGroup1,
               cm_memberDims1, texturePosition, 1);
#endif
#if CM_VOLUME_COUNT > 2
  cm_addMember(sum, cm_member2, cm_memberTable2, cm_memberClim2, cm_memberFromGroup2,
               cm_memberDims2, texturePosition, 2);
#endif
#if CM_VOLUME_COUNT > 3
  cm_addMember(sum, cm_member3, cm_memberTable3, cm_memberClim3, cm_memberFromGroup3,
               cm_memberDims3, texturePosition, 3);
#endif
  return vec4(sum.a > 0.0 ? sum.rgb / sum.a : vec3(0.0), sum.a);
}

// Where the ray from a to b (group texture coordinates) runs inside a member's box of texel
// centres, as fractions enter..leave of it (both 2 when it misses), and the member's texels
// the whole ray spans along its dominant axis (the march steps each piece on its finest grid).
void cm_memberSpan(mat4 fromGroup, vec3 dims, vec3 a, vec3 b, out float enter,
                   out float leave, out float texels)
{
  vec3 p = (fromGroup * vec4(a, 1.0)).xyz;
  vec3 d = (fromGroup * vec4(b, 1.0)).xyz - p;
  vec2 inBox = cm_slab(p, d, 0.5 / dims, 1.0 - 0.5 / dims);
  enter = clamp(inBox.x, 0.0, 1.0);
  leave = clamp(inBox.y, 0.0, 1.0);
  if (!(leave > enter))
  {
    enter = 2.0;
    leave = 2.0;
  }
  vec3 spanTexels = abs(d) * dims;
  texels = max(spanTexels.x, max(spanTexels.y, spanTexels.z));
}

// Every member's span along the ray, one per component (unused components: 2, 2, 0).
void cm_memberSpans(vec3 a, vec3 b, out vec4 enter, out vec4 leave, out vec4 texels)
{
  enter = vec4(2.0);
  leave = vec4(2.0);
  texels = vec4(0.0);
  cm_memberSpan(cm_memberFromGroup0, cm_memberDims0, a, b, enter.x, leave.x, texels.x);
#if CM_VOLUME_COUNT > 1
  cm_memberSpan(cm_memberFromGroup1, cm_memberDims1, a, b, enter.y, leave.y, texels.y);
#endif
#if CM_VOLUME_COUNT > 2
  cm_memberSpan(cm_memberFromGroup2, cm_memberDims2, a, b, enter.z, leave.z, texels.z);
#endif
#if CM_VOLUME_COUNT > 3
  cm_memberSpan(cm_memberFromGroup3, cm_memberDims3, a, b, enter.w, leave.w, texels.w);
#endif
}
