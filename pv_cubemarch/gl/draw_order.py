"""The order VTK composites translucent props and volumes in: farthest first, by their boxes.

VTK blends a renderer's translucent props, and draws its volumes, in the order of its prop
list (without depth peeling), so two volumes one behind the other composite in the order
they were added: the far one over the near one when the near one came first. Sorting our
volumes' props farthest first, in the slots they already hold, composites the nearer over
the farther (the cube map's overlay sorts its volumes so too); other props keep their
places.
"""

from __future__ import annotations

import numpy as np


def sort_far_to_near(renderer, props, eye=None) -> bool:
    """Put ``props`` (in ``renderer``'s prop list) farthest first, in the slots they hold.

    Distance: from ``eye`` (by default the renderer's camera) to each prop's box centre.
    The list is rewritten in place (``ReplaceItem``: no prop leaves the renderer, so none
    releases its graphics resources). Returns whether the order changed.
    """
    collection = renderer.GetViewProps()
    listed = [collection.GetItemAsObject(i) for i in range(collection.GetNumberOfItems())]
    slots = [i for i, prop in enumerate(listed) if any(prop is p for p in props)]
    if len(slots) < 2:
        return False
    eye = np.array(renderer.GetActiveCamera().GetPosition() if eye is None else eye,
                   dtype=np.float64)
    mine = [listed[i] for i in slots]
    ordered = sorted(mine, key=lambda p: -np.linalg.norm(np.array(p.GetCenter()) - eye))
    if all(a is b for a, b in zip(ordered, mine, strict=True)):
        return False
    for slot, prop in zip(slots, ordered, strict=True):
        collection.ReplaceItem(slot, prop)
    return True
