"""The documentation: generated from the code and the measurements, and honest about both."""

from __future__ import annotations

import ast
import importlib
import inspect
import json
import pkgutil
import re
import sys

import pytest
from conftest import ROOT

import pv_cubemarch
from pv_cubemarch.core.declared import declared

sys.path.insert(0, str(ROOT / "docs" / "_scripts"))
import generate_pages  # noqa: E402


def _keywords_used(paths) -> set[str]:
    """Keyword arguments of every call in ``paths``, and the keys of dict(...) calls."""
    used = set()
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.keyword) and node.arg:
                used.add(node.arg)
            if isinstance(node, ast.Dict):
                used |= {k.value for k in node.keys if isinstance(k, ast.Constant)}
    return used


EXAMPLE_KEYWORDS = _keywords_used(sorted((ROOT / "examples").rglob("*.py")))
#: A paper's numbering: section, table, figure, equation, listing, or the seed documents'
#: file numbers used as names.
PAPER_NUMBERING = re.compile(
    r"seed's|\bthe seed\b|\b(?:section|Table|Tables|Figure|figure|Eq\.|Listing) ?\d"
    r"|\((?:000|001|002|003|004)\b|\b(?:000|002|003|004)'s|\bof (?:000|002|003|004)\b"
    r"|\bII\.[A-H]\b")


@pytest.mark.parametrize("kind", ["volume", "voxels", "surface"])
def test_every_declared_option_appears_in_an_example(kind):
    # catches: an option added without a gallery example passing it (seen failing with
    # max_samples=32 turned into face_size=32 in examples/volumes/speed_knobs.py)
    missing = [o.name for o in declared(kind) if o.name not in EXAMPLE_KEYWORDS]
    assert not missing, f"declared {kind} options no example uses: {missing}"


def _public_objects():
    for info in pkgutil.walk_packages(pv_cubemarch.__path__, "pv_cubemarch."):
        module = importlib.import_module(info.name)
        yield info.name, module
        for name, value in vars(module).items():
            if name.startswith("_") or getattr(value, "__module__", None) != info.name:
                continue
            if inspect.isclass(value) or inspect.isfunction(value):
                yield f"{info.name}.{name}", value
                if inspect.isclass(value):
                    for attribute, member in vars(value).items():
                        if not attribute.startswith("_") and callable(member):
                            yield f"{info.name}.{name}.{attribute}", member


def test_no_public_docstring_cites_paper_numbering():
    # catches: "the seed's M" or "section 3.4 of 000" in a docstring a user reads (seen
    # failing on api.add_surface before the docstrings were rewritten); the glossary is
    # the one place for them
    cited = {name: PAPER_NUMBERING.search(doc).group(0)
             for name, value in _public_objects()
             if (doc := inspect.getdoc(value)) and PAPER_NUMBERING.search(doc)}
    assert not cited, cited


def test_cli_help_cites_no_paper_numbering():
    # catches: "Table 1 of 000" in `pv-cubemarch bench --help`
    text = generate_pages.cli_markdown()
    assert "pv-cubemarch bench tradeoff" in text
    assert not PAPER_NUMBERING.search(text), PAPER_NUMBERING.search(text).group(0)


def test_docs_pages_outside_the_glossary_cite_no_paper_numbering():
    pages = [p for p in (ROOT / "docs").glob("*.md") if p.name != "glossary.md"]
    pages.append(ROOT / "README.md")
    cited = {p.name: m.group(0) for p in pages if (m := PAPER_NUMBERING.search(p.read_text()))}
    assert not cited, cited


def test_bench_tables_are_generated_not_pasted():
    # catches: a measured table pasted into a page by hand (the pages include the tables
    # generate_pages.py writes from docs/bench_results/*.json)
    pasted = {}
    for page in [*(ROOT / "docs").glob("*.md"), ROOT / "README.md"]:
        for block in fenced_blocks(page.read_text()):
            if re.search(r"median ms|PSNR dB|wrong %|ms/frame|frame ms|latency ms", block):
                pasted[page.name] = block.splitlines()[0]
    assert not pasted, pasted


def fenced_blocks(text: str) -> list[str]:
    """The bodies of the ``` blocks of a Markdown page (directives included)."""
    blocks, body = [], None
    for line in text.splitlines():
        if line.startswith("```"):
            if body is None:
                body = []
            else:
                blocks.append("\n".join(body))
                body = None
        elif body is not None:
            body.append(line)
    return blocks


def test_bench_json_becomes_a_table_of_its_rows(tmp_path):
    # catches: a row dropped or a value rounded into another (the table is read back)
    payload = {"command": "pv-cubemarch bench tradeoff direct --json /somewhere/t.json",
               "meta": {"size": [64, 48], "gl_renderer": "some GPU"},
               "results": [
                   {"technique": "direct", "setting": "step_scale=0.5", "median_ms": 12.5,
                    "errors": {"psnr": 51.234, "ssim": 0.99, "max_abs": 3}, "pareto": True,
                    "parameters": {"blending": "composite"}, "frame_ms": [12, 13]},
                   {"technique": "pyvista", "setting": "step_scale=1.0", "median_ms": 25.0,
                    "errors": {"psnr": 40.0, "ssim": 0.9, "max_abs": 9}, "pareto": False,
                    "parameters": {"blending": "composite"}, "frame_ms": [25, 25]}]}
    path = tmp_path / "t.json"
    path.write_text(json.dumps(payload))
    text = generate_pages.bench_markdown("t", path)
    rows = [line for line in text.splitlines() if line.startswith("| direct")
            or line.startswith("| pyvista")]
    assert len(rows) == 2
    assert "| 12.5 | 1.00 | 51.23 |" in rows[0] and "| * |" in rows[0]
    assert "| 25.0 | 2.00 | 40.00 |" in rows[1]
    assert "some GPU" in text and "--json t.json" in text and "/somewhere" not in text


def test_generated_tables_name_settings_by_their_options(tmp_path):
    # catches: a sweep labelled in the papers' symbols (S0=, N_max=, k_u=) instead of the
    # keywords a user passes (seen failing with the cube map's old labels)
    written = generate_pages.generate_all(ROOT / "docs")
    text = "\n".join(path.read_text() for path in written if path.suffix == ".md")
    assert "face_size=" in text
    found = re.findall(r"\b(?:S0|N_max|k_u|k_c|k_z|down)=", text)
    assert not found, found


def test_every_bench_result_in_the_docs_is_included_by_a_page():
    # catches: a measurement committed that no page shows, or a page including a table
    # whose JSON is missing (the build would fail later, on a machine with the docs extra)
    pages = "\n".join(p.read_text() for p in (ROOT / "docs").glob("*.md"))
    results = {p.stem for p in (ROOT / "docs" / "bench_results").glob("*.json")}
    included = set(re.findall(r"_generated/bench_(\w+)\.md", pages)) - {"commands"}
    assert included == results


def test_readme_is_short_and_leads_to_labels_and_docs():
    text = (ROOT / "README.md").read_text()
    lines = text.splitlines()
    assert 120 <= len(lines) <= 210, len(lines)
    assert "pip install" in text and "tools/build_docs.sh" in text
    assert "bash tools/setup.sh && .venv/bin/python -m pytest -q" in text
    first_screen = "\n".join(lines[:60])
    assert "add_voxels" in first_screen                 # labels within the first screen


def test_front_page_shows_labels_on_its_first_screen():
    lines = (ROOT / "docs" / "index.md").read_text().splitlines()
    assert any("add_voxels" in line for line in lines[:50])


def test_readme_examples_run(tmp_path):
    # catches: a README example that no longer runs (they are run in order, as one script,
    # offscreen, as a reader would paste them)
    import subprocess

    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert len(blocks) == 3
    script = ("import pyvista as pv\npv.OFF_SCREEN = True\n" + "\n".join(blocks)
              + "\nprint('ran', len(pv.plotting.plotter._ALL_PLOTTERS))\n")
    result = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "VoxelPick(" in result.stdout


def test_front_page_example_runs(tmp_path):
    # catches: the docs' first example rotting (a colormap that is not installed, a
    # keyword renamed)
    import subprocess

    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "index.md").read_text(), re.S)
    script = "import pyvista as pv\npv.OFF_SCREEN = True\n" + blocks[0]
    result = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
