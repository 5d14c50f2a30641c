"""The GLSL assembler: snippets, defines, and compile errors as Python exceptions."""

from __future__ import annotations

import numpy as np
import pytest

import pv_cubemarch as cm
from pv_cubemarch.gl import shaders
from pv_cubemarch.gl.shaders import Replacement, ShaderRecipe, define_lines, snippet_source


def test_every_shipped_snippet_loads():
    from importlib import resources

    names = [p.name[:-5] for folder in resources.files(shaders.SNIPPET_PACKAGE).iterdir()
             if folder.is_dir() for p in folder.iterdir() if p.name.endswith(".glsl")]
    assert {"ea_declarations", "ea_march", "ea_vtk_ray_init", "ea_vtk_declarations"} <= set(names)
    for name in names:
        assert snippet_source(name).strip()


def test_unknown_snippet_lists_known_ones():
    with pytest.raises(FileNotFoundError, match="ea_declarations"):
        snippet_source("no_such_snippet")


def test_defines_only_for_enabled_features():
    text = define_lines({"CM_A": True, "CM_B": False, "CM_N": 4, "CM_C": None})
    assert text.splitlines() == ["#define CM_A 1", "#define CM_N 4"]


def test_defines_switch_code_in_assembled_shader():
    recipe = ShaderRecipe([Replacement("//VTK::Color::Dec", "debug_view_declarations",
                                       keep_tag="after")], defines={"CM_VIEW_3D": True})
    code = recipe.code_for(recipe.replacements[0], first=True)
    assert "#define CM_VIEW_3D 1" in code and "CM_VIEW_2D 1" not in code
    assert code.rstrip().endswith("//VTK::Color::Dec")


def test_snippet_with_a_vtk_tag_is_refused(monkeypatch, tmp_path):
    snippet_source.cache_clear()
    shaders._snippet_paths.cache_clear()
    (tmp_path / "common").mkdir()
    (tmp_path / "common" / "tagged.glsl").write_text("// uses //VTK::Light::Impl in a comment\n")
    monkeypatch.setattr(shaders.resources, "files", lambda package: tmp_path)
    try:
        with pytest.raises(ValueError, match="VTK tag"):
            snippet_source("tagged")
    finally:
        monkeypatch.undo()
        snippet_source.cache_clear()
        shaders._snippet_paths.cache_clear()


def test_compile_error_raises_with_snippet_name(monkeypatch, plotter_factory, blob):
    original = shaders.snippet_source

    def broken(name):
        if name == "ea_vtk_ray_init":
            return "float cm_broken = ;"
        return original(name)

    monkeypatch.setattr(shaders, "snippet_source", broken)
    pl = plotter_factory((32, 32))
    cm.add_volume(pl, blob)
    with pytest.raises(cm.ShaderCompileError) as info:
        cm.render_frame(pl)
    assert info.value.snippets == ("ea_vtk_ray_init",)
    assert "error" in info.value.log.lower()
    assert "ea_vtk_ray_init" in str(info.value)


def test_working_shader_raises_nothing(plotter_factory, blob):
    pl = plotter_factory((32, 32))
    cm.add_volume(pl, blob)
    cm.render_frame(pl)
    assert np.asarray(cm.render_image(pl)).std() > 0
