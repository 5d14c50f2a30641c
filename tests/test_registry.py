"""Techniques register themselves; add_volume validates only the chosen technique's options."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pv_cubemarch as cm
from pv_cubemarch.bench import harness
from pv_cubemarch.core.registry import get_technique, techniques


def test_every_volume_technique_is_registered_whole():
    names = [t.name for t in techniques("volume")]
    assert sorted(names) == ["auto", "cubemap", "direct", "vtk"]
    for technique in techniques("volume"):
        assert dataclasses.is_dataclass(technique.options)
        assert callable(technique.build) and technique.reference is cm.render_emission_absorption
        technique.options().check()   # the defaults are valid


def test_bench_rows_come_from_the_registry():
    sweeps = harness.sweeps()
    assert {t.name for t in techniques("volume") if t.sweep} | {"pyvista"} == set(sweeps)
    for name, sweep in sweeps.items():
        if name != "pyvista":   # each setting is a valid set of that technique's options
            for setting in sweep.settings:
                get_technique("volume", name).make_options(setting)


@pytest.mark.parametrize(("technique", "option", "users"), [
    ("cubemap", {"step_scale": 0.5}, "'auto' or 'direct' or 'vtk'"),
    ("vtk", {"downsample": 2}, "'direct'"),
    ("direct", {"face_size": 64}, "'auto' or 'cubemap'"),
    ("vtk", {"max_samples": 10}, "'auto' or 'cubemap'"),
])
def test_an_option_of_another_technique_is_an_error_naming_its_users(plotter_factory, technique,
                                                                      option, users):
    # catches: an option the chosen technique ignores being dropped silently (the old
    # add_volume took step_scale with technique='cubemap' and did nothing with it).
    pl = plotter_factory()
    name = next(iter(option))
    with pytest.raises(ValueError, match=f"{name} is not an option of technique='{technique}'"
                       f"; it is used by technique={users}"):
        cm.add_volume(pl, np.ones((4, 4, 4)), technique=technique, **option)


def test_unknown_technique_lists_the_registered_ones(plotter_factory):
    names = r"\('auto', 'cubemap', 'direct', 'vtk'\)"
    with pytest.raises(ValueError, match=f"technique must be one of {names}"):
        cm.add_volume(plotter_factory(), np.ones((4, 4, 4)), technique="raymarch")


def test_options_of_the_chosen_technique_are_checked(plotter_factory):
    pl = plotter_factory()
    with pytest.raises(ValueError, match="face_size must be a power of two"):
        cm.add_volume(pl, np.ones((4, 4, 4)), technique="auto", face_size=100)
    with pytest.raises(ValueError, match="step_scale"):
        cm.add_volume(pl, np.ones((4, 4, 4)), technique="auto", step_scale=1e-9)
