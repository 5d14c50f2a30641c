"""Where a streamed volume's rays stop: the depth its pager culls hidden bricks by.

A label grid writes the depth of what it hits; a volume writes none (it blends). Before
each plan of its pager (a new view, or bricks still missing; not the first frame, which
draws the coarsest level at once), a pass marches the same rays with the same steps as
the box over what the pool holds, and writes per pixel the window depth of the sample
where the opacity passed ``stop_opacity``: the marcher stops there, and what lies behind
reaches no pixel. Read back at once, that depth culls the bricks behind it as a label
grid's does (:mod:`.occluded_bricks`). The pass runs on no other frame, and never for a
transfer function whose densest value cannot stop a ray crossing the whole box.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np

from ..core.errors import ShaderCompileError
from ..gl.box import bind_camera, drawn_viewport
from ..gl.passes import RenderToTexturePass
from ..gl.shaders import ShaderRecipe
from .binding import DECLARATION_SNIPPETS, march_snippets, world_from_texture
from .occluded_bricks import DepthPyramid


def rays_can_stop(model, stop_opacity: float) -> bool:
    """Whether any ray through ``model`` can pass ``stop_opacity``.

    The densest extinction of the transfer table over the box's diagonal (in the data's
    units, as the marcher measures opacity) bounds every ray's opacity from above.
    """
    extinction = float(np.max(model.transfer.table[:, 3]))
    span = model.dataset_from_index()[:3, :3] @ (np.asarray(model.dimensions, float) - 1.0)
    return 1.0 - np.exp(-extinction * float(np.linalg.norm(span))) > stop_opacity


def follow_stop_depth(binding, bind_sampling: Callable[[object], dict]
                      ) -> RenderToTexturePass:
    """Give the pager of ``binding``'s volume the depth where its rays stop, before each plan.

    ``bind_sampling(target)`` gives a pass what the
    box's marcher reads and returns its switches. The pass recompiles with the binding's
    marchers (a clipping plane added) and is freed with it.
    """
    renderer, data, model = binding.renderer, binding.data, binding.model
    pager = data.pager
    depth_pass = RenderToTexturePass(renderer, None, size=lambda: drawn_viewport(renderer)[2:],
                                     targets=("r32f",), on_demand=True)
    switches = bind_sampling(depth_pass)
    bind_camera(depth_pass, renderer, lambda: world_from_texture(model))
    depth_pass.set_recipe(ShaderRecipe(
        standalone=("pass_head", *DECLARATION_SNIPPETS, "paged_bricks", "paged_sample",
                    "camera_declarations", *march_snippets("composite", switches),
                    "pixel_ray", "screen_ray", "ea_stop_depth_main"),
        defines={**switches, "CM_STOP_DEPTH": True}))

    def depth_now():
        try:
            ran = depth_pass.run_now()
        except ShaderCompileError as error:   # drawn as before, every brick in view read
            pager.cull_hidden = False
            warnings.warn(f"the pass finding where a streamed volume's rays stop did not "
                          f"compile; its hidden bricks are read too: {error}",
                          RuntimeWarning, stacklevel=2)
            return None
        if not ran:
            return None
        return DepthPyramid(depth_pass.read(0)[..., 0], tuple(drawn_viewport(renderer)[:2]))

    pager.cull_hidden = True
    pager.depth_before_plan = depth_now
    # a moved plane uncovers what it cut; nearest reads stop rays elsewhere than linear
    pager.drawn_state = lambda: (data.clip.planes, model.interpolation)
    binding.targets.append(depth_pass)
    binding.extra_release.append(depth_pass.release)
    return depth_pass
