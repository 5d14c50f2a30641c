"""``actor.cubemarch.set_transform`` moves every technique's drawing as ``transform=`` places it.

The oracle is the same data added with ``transform=`` from the start (the placement path
every technique's image tests already hold to its CPU reference): moving an actor later
must draw the same image, for every technique the registry lists.
"""

from __future__ import annotations

import numpy as np
import pytest

import pv_cubemarch as cm
from pv_cubemarch.core.registry import techniques

SIZE = (96, 72)
CAMERA = [(70.0, -55.0, 60.0), (14.0, 10.0, 9.0), (0.0, 0.0, 1.0)]
#: A turn of 20 degrees about z, a stretch and a shift: every placement term at once.
ANGLE = np.radians(20.0)
MOVE = np.array([[np.cos(ANGLE), -np.sin(ANGLE), 0.0, 14.0],
                 [np.sin(ANGLE), np.cos(ANGLE), 0.0, -10.0],
                 [0.0, 0.0, 1.3, 2.0],
                 [0.0, 0.0, 0.0, 1.0]])


def blob() -> np.ndarray:
    x, y, z = np.mgrid[0:24, 0:20, 0:16].astype(float)
    return np.exp(-((x - 10) ** 2 + (y - 9) ** 2 + (z - 7) ** 2) / 30.0)


def labels() -> np.ndarray:
    grid = np.zeros((24, 20, 16), np.uint8)
    grid[4:14, 3:12, 2:9] = 1
    grid[14:20, 8:18, 5:14] = 2
    return grid


def cases():
    """(kind, technique, add): one per registered technique, and the voxel world paths."""
    for technique in techniques("volume"):
        yield "volume", technique.name, lambda pl, t, name=technique.name: cm.add_volume(
            pl, blob(), technique=name, cmap="viridis", opacity="linear",
            opacity_unit_distance=4.0, transform=t)
    for technique in techniques("voxels"):
        yield "voxels", technique.name, lambda pl, t: cm.add_voxels(
            pl, labels(), palette=["black", "tomato", "teal"], transform=t)
        for world in ("index", "per_chunk"):
            yield "voxels", f"{technique.name} world {world}", lambda pl, t, w=world: \
                cm.add_voxels(pl, labels(), palette=["black", "tomato", "teal"],
                              chunk_size=8, world_traversal=w, transform=t)
    for technique in techniques("surface"):
        yield "surface", technique.name, lambda pl, t, name=technique.name: cm.add_surface(
            pl, blob(), isovalue=0.4, technique=name, cells=12, transform=t)
    yield "surface", "isosurfaces", lambda pl, t: cm.add_surface(
        pl, blob(), isosurfaces=[0.3, 0.6], cells=12, transform=t)


CASES = list(cases())


def draw(add, transform, move_later=None) -> np.ndarray:
    pl = cm.offscreen_plotter(SIZE)
    pl.set_background("black")
    actor = add(pl, transform)
    actor = actor[0] if isinstance(actor, list) else actor
    pl.camera_position = CAMERA
    pl.camera.clipping_range = (1.0, 400.0)
    cm.render_image(pl)
    if move_later is not None:
        actor.cubemarch.set_transform(move_later)
        pl.camera.clipping_range = (1.0, 400.0)
    image = cm.render_image(pl).astype(int)
    pl.close()
    return image


@pytest.mark.parametrize("kind, name, add", CASES, ids=[f"{k}-{n}" for k, n, _ in CASES])
def test_set_transform_draws_what_transform_places(kind, name, add):
    # catches (seen failing): the model's new placement not stored (every case); place()
    # skipped, so the boxes stay where they were (every volume and voxel case; a surface's
    # box follows its per-draw placement uniform); the voxel grid's brick shell left where
    # it was (shell.place() removed: the voxels case)
    placed = draw(add, MOVE)
    moved = draw(add, None, move_later=MOVE)
    still = draw(add, None)
    assert np.abs(placed - still).max() > 60          # the move shows: no background pass
    difference = np.abs(placed - moved)
    assert (difference.max(axis=-1) > 8).mean() < 0.002, (kind, name)


@pytest.mark.parametrize("kind, name, add", CASES, ids=[f"{k}-{n}" for k, n, _ in CASES])
def test_remove_actor_frees_what_every_technique_holds(kind, name, add):
    # catches (seen failing): release_resources not called by the handle's release (the
    # bindings' textures stay on the GPU: every case but the per-chunk world's, whose
    # chunks are tracked and freed one by one), and a removed drawing still drawn
    pl = cm.offscreen_plotter(SIZE)
    pl.set_background("black")
    actor = add(pl, None)
    actor = actor[0] if isinstance(actor, list) else actor
    pl.camera_position = CAMERA
    assert cm.render_image(pl).max() > 60
    binding = actor.cubemarch
    textures = [t for t in getattr(getattr(binding, "bindings", None), "textures", {}).values()
                if isinstance(t, cm.Texture)]    # not the frame's depth or a pass's output
    assert pl.remove_actor(actor)
    assert cm.render_image(pl).max() == 0
    assert pl.cubemarch.tracked == []
    assert all(texture.gl_object is None for texture in textures), name
    pl.close()
