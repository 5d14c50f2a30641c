"""``pv-cubemarch bench device``: Mesa's rows matched and judged, sections that fail or run
out of budget reported rather than fatal. The GPU run itself happens only on a GPU machine
(tools/device_check.sh); these tests check the judging and the bookkeeping by hand.
"""

from __future__ import annotations

import json

import pytest

from pv_cubemarch.bench import device
from pv_cubemarch.bench.device import Section, compare_with_mesa, run_device_check


def _tradeoff(rows):
    return {"results": [{"technique": t, "setting": s, "parameters": {"blending": "composite"},
                         "errors": None if p is None else {"psnr": p}} for t, s, p in rows],
            "meta": {"gl_renderer": "llvmpipe"}}


def test_tradeoff_rows_are_matched_by_setting_and_judged_within_a_decibel():
    # catches (seen failing): rows matched by position instead of by setting (the swapped
    # pair then disagrees), and a 1 dB tolerance read the wrong way round (gpu <= mesa)
    mesa = _tradeoff([("direct", "step_scale=1.0", 62.0), ("direct", "step_scale=2.0", 50.0),
                      ("vtk", "step_scale=1.0", 61.0)])
    gpu = _tradeoff([("direct", "step_scale=2.0", 49.5), ("direct", "step_scale=1.0", 58.0),
                     ("vtk", "step_scale=1.0", None), ("cubemap", "face_size=64", 55.0)])
    found = compare_with_mesa("tradeoff", gpu, mesa)
    assert found["matched"] == 2 and found["disagree"] == 1
    verdict = {tuple(r["row"][:2]): r["agrees"] for r in found["rows"]}
    assert verdict == {("direct", "step_scale=2.0"): True, ("direct", "step_scale=1.0"): False}
    # a row with no error on either side, or none on Mesa, is listed, not judged
    assert ["vtk", "step_scale=1.0", "composite"] in found["unmatched"]
    assert ["cubemap", "face_size=64", "composite"] in found["unmatched"]
    assert found["metric"] == "psnr" and found["mesa_renderer"] == "llvmpipe"


def test_both_past_sixty_decibels_agree_whatever_the_gap():
    # catches (seen failing): the 60 dB floor dropped (70 against 63 dB would disagree)
    mesa = _tradeoff([("direct", "a", 70.0)])
    gpu = _tradeoff([("direct", "a", 63.0)])
    assert compare_with_mesa("tradeoff", gpu, mesa)["disagree"] == 0


def test_voxel_and_surface_rows_are_judged_on_their_own_errors():
    # catches (seen failing): wrong pixels compared as a PSNR (more wrong read as better)
    mesa = {"results": [{"scene": "s", "row": "dda", "size": [4, 4], "wrong_percent": 0.01},
                        {"scene": "s", "row": "fixed", "size": [4, 4], "wrong_percent": 1.0}]}
    gpu = {"results": [{"scene": "s", "row": "dda", "size": [4, 4], "wrong_percent": 0.5},
                       {"scene": "s", "row": "fixed", "size": [4, 4], "wrong_percent": 1.04}]}
    found = compare_with_mesa("voxels", gpu, mesa)
    assert [r["agrees"] for r in found["rows"]] == [False, True]
    mesa = {"rows": [{"shape": "nut", "cells": 32, "row": "ours", "iou": 0.997}]}
    gpu = {"rows": [{"shape": "nut", "cells": 32, "row": "ours", "iou": 0.990}]}
    assert compare_with_mesa("surfaces", gpu, mesa)["disagree"] == 1


@pytest.mark.slow   # long (8 s): its own CI step (pytest -m slow)
def test_a_failing_section_and_a_spent_budget_are_reported_and_the_plan_goes_on(
        tmp_path, monkeypatch):
    # catches (seen failing): a section's failure raised out of the plan (the next section
    # never ran), and sections started with no budget left
    plan = (Section("broken", ("no-such-bench",), 60),
            Section("fine", ("no-such-bench-either",), 60),
            Section("late", ("no-such-bench",), 60))
    monkeypatch.setitem(device.PLANS, "test", plan)
    clock = iter([0.0, 0.0, 1.0, 2.0, 3.0, 200.0, 201.0, 202.0, 203.0])
    monkeypatch.setattr(device.time, "perf_counter", lambda: next(clock))
    report = run_device_check(tmp_path, "test", budget=100.0, gl=lambda: {"renderer": "x"})
    written = json.loads((tmp_path / "device.json").read_text())
    assert written["gl"] == {"renderer": "x"}
    sections = {s["name"]: s for s in report["sections"]}
    assert sections["broken"]["rc"] == 2 and "invalid choice" in sections["broken"]["log_tail"]
    assert sections["fine"]["rc"] == 2
    assert sections["late"]["skipped"].startswith("budget spent")
    assert [s["name"] for s in written["sections"]] == ["broken", "fine", "late"]


def test_an_unknown_plan_or_section_is_refused_by_name(tmp_path):
    with pytest.raises(ValueError, match="plan must be one of"):
        run_device_check(tmp_path, "huge")
    with pytest.raises(ValueError, match=r"No section \['nope'\]"):
        run_device_check(tmp_path, "quick", sections=["nope"])


def test_the_gpu_plan_runs_mesa_s_own_commands_where_it_compares_with_them():
    # the parity sections must repeat the committed Mesa command's settings, or the rows
    # they match would not be the same images
    for section in device.PLANS["gpu"]:
        if section.mesa is None:
            continue
        mesa = json.loads((device.MESA_RESULTS / f"{section.mesa}.json").read_text())
        command = mesa["command"].split()
        ours = [a for a in section.args if a not in ("--workers", device.REFERENCE_WORKERS)]
        assert command[2:2 + len(ours)] == ours or set(ours) <= set(command), section.name
