"""Snippets declare what they need (``// requires:``) and the assembler holds recipes to it."""

from __future__ import annotations

import re

import pytest

from pv_cubemarch.gl.shaders import (
    Replacement,
    ShaderRecipe,
    _snippet_paths,
    snippet_requirements,
    snippet_source,
)

NAMES = sorted(_snippet_paths())


def _defined_by() -> dict[str, set[str]]:
    owners: dict[str, set[str]] = {}
    for name in NAMES:
        for match in re.finditer(r"^(?:[A-Za-z_]\w*\s+)+(cm_\w+)\s*\([^;]*?\)\s*\{",
                                 snippet_source(name), re.M):
            owners.setdefault(match.group(1), set()).add(name)
    return owners


def _unconditional_code(text: str) -> str:
    kept, depth = [], 0
    for line in text.splitlines():
        stripped = line.strip()
        if stripped.startswith("#if"):
            depth += 1
        elif stripped.startswith("#endif"):
            depth -= 1
        elif depth == 0 and not stripped.startswith("//"):
            kept.append(line)
    return "\n".join(kept)


OWNERS = _defined_by()


@pytest.mark.parametrize("name", NAMES)
def test_a_snippet_declares_the_snippets_whose_functions_it_calls(name):
    # catches: a function called from a snippet that does not say it needs the one
    # defining it (seen failing with 'pixel_ray' taken out of screen_ray's requires line).
    # Functions several snippets define (a blend mode's, a sampler's) are chosen by the
    # recipe, and calls inside #if blocks are optional: neither is asked for.
    calls = set(re.findall(r"\b(cm_\w+)\s*\(", _unconditional_code(snippet_source(name))))
    needed = {next(iter(owners)) for call in calls
              if len(owners := OWNERS.get(call, set())) == 1 and name not in owners}
    assert needed <= set(snippet_requirements(name)), sorted(needed)


def test_a_recipe_without_a_required_snippet_is_refused_by_name():
    # catches: ShaderRecipe.apply/fragment_source no longer checking (the GLSL would fail
    # to compile later, with VTK's line numbers instead of the snippet's name)
    recipe = ShaderRecipe([Replacement("//VTK::Light::Impl", ("slab", "screen_ray"))])
    with pytest.raises(ValueError, match=r"'screen_ray' requires \['camera_declarations', "
                                         r"'pixel_ray'\]"):
        recipe.check()
    ShaderRecipe([Replacement("//VTK::Light::Impl", ("camera_declarations", "slab",
                                                      "pixel_ray", "screen_ray"))]).check()


def test_requirements_name_snippets_that_exist():
    for name in NAMES:
        assert set(snippet_requirements(name)) <= set(NAMES), name
