// requires: joint_sample
// Channels that add their light (a channel volume's channel_blending='additive'): each
// channel is composited front to back as if it were alone, with its own transmittance,
// and the channels' light is summed (clamped to white); what lies behind is seen through
// all of them. Needs cm_channelEmissions (joint_sample with CM_CHANNELS_ADDITIVE).
vec4 cm_channelTransmittance;   // each channel's transmittance so far (unused ones: 1)

vec4 cm_blendStart()
{
  cm_channelTransmittance = vec4(1.0);
  return vec4(0.0);
}

bool cm_blend(inout vec4 state, vec3 texturePosition, float dt)
{
  mat4 emissions;
  cm_channelEmissions(texturePosition, emissions);
  vec4 extinction = vec4(emissions[0].a, emissions[1].a, emissions[2].a, emissions[3].a);
  vec4 weight = cm_channelTransmittance * (1.0 - exp(-extinction * dt));
  state.rgb += (emissions * weight).rgb;   // the sum over channels of weight * colour
  cm_channelTransmittance -= weight;
  vec4 t = cm_channelTransmittance;
  state.a = 1.0 - t.x * t.y * t.z * t.w;
  // Until every channel is opaque enough (the unused ones, whose transmittance stays 1,
  // left out).
  vec4 used = vec4(1.0, float(CM_VOLUME_COUNT > 1), float(CM_VOLUME_COUNT > 2),
                   float(CM_VOLUME_COUNT > 3));
  return any(greaterThan(t * used, vec4(1.0 - cm_stopOpacity)));
}

vec4 cm_blendResult(vec4 state)
{
  return vec4(min(state.rgb, vec3(1.0)), state.a);
}
