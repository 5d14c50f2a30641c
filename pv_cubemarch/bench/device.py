"""``pv-cubemarch bench device``: the headline benches on a GPU machine, beside Mesa's rows.

Each bench runs as its own process with its own time limit, so a crash or a hang costs one
section, and the plan stops starting sections when its budget is spent. The rows a section
shares with a committed Mesa run (``docs/bench_results``) are compared error for error:
the same image on the GPU as on Mesa means the same error against the CPU reference, which
shares no code with either. Everything lands in one JSON (and one log), because the
machines that lend a GPU hand back only a few files.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..core.offscreen import gl_info
from .sort_last import phantom

MESA_RESULTS = Path(__file__).resolve().parents[2] / "docs" / "bench_results"
#: Processes the CPU references are spread over on the GPU machine (it has 16 cores).
REFERENCE_WORKERS = "8"


@dataclass(frozen=True)
class Section:
    """One bench command of the plan: its ``pv-cubemarch bench`` arguments and limits."""

    name: str
    args: tuple[str, ...]
    seconds: float
    #: ``docs/bench_results/<mesa>.json``: the same command's rows on Mesa, or None.
    mesa: str | None = None
    #: A grid file the section reads (``{grid}`` in ``args``): (points a side, writer).
    grid: tuple[int, Callable] | None = None


def _write_phantom(path: Path, side: int) -> None:
    np.save(path, phantom((side, side, side)))


def _plans() -> dict[str, tuple[Section, ...]]:
    workers = ("--workers", REFERENCE_WORKERS)
    parity = (
        Section("tradeoff", ("tradeoff", "vtk", "direct", "cubemap", "pyvista", *workers),
                150, "tradeoff"),
        Section("voxels", ("voxels", "--sizes", "400x400", "--frames", "3", *workers), 150,
                "voxels"),
        Section("surfaces", ("surfaces", "--size", "400x400", "--grids", "32,64", "--steps",
                             "50,500", "--frames", "3", *workers), 120, "surfaces"),
        Section("resolution", ("resolution", "--frames", "3", *workers), 150, "resolution"),
    )
    # the GPU's scale, the heaviest CPU references last: a section that overruns costs
    # only itself and those after it
    scale = (
        Section("cluster", ("cluster", "--scenes", "smoke,direct,cubemap,voxels,surface",
                            "--workers", "1,2,4,8"), 200),
        Section("dial", ("dial", "--size", "1280x720", "--orbit-size", "1920x1080",
                         "--budget-ms", "8"), 150),
        Section("sortlast", ("sortlast", "--shape", "384x384x384", "--size", "1280x720",
                             "--workers", "8"), 150),
        Section("volume-512", ("tradeoff", "direct", "vtk", "--scene", "{grid}", "--size",
                               "480x270", "--no-stock", *workers), 150,
                grid=(512, _write_phantom)),
        Section("surfaces-1000", ("surfaces", "--size", "1000x1000", "--grids", "128,512",
                                  "--steps", "50,500", "--frames", "5", *workers), 150),
        Section("voxels-1000", ("voxels", "--sizes", "1000x1000", "--large", "512",
                                "--frames", "5", *workers), 150),
    )
    quick = (
        Section("surfaces", ("surfaces", "--size", "400x400", "--grids", "32", "--steps",
                             "50", "--shapes", "nut", "--frames", "3"), 120, "surfaces"),
        Section("volume-32", ("tradeoff", "direct", "--scene", "{grid}", "--size", "160x120",
                              "--no-stock", "--frames", "3"), 120, grid=(32, _write_phantom)),
    )
    return {"gpu": parity + scale, "quick": quick}


PLANS = _plans()


@dataclass
class SectionResult:
    """What one section did: its command, exit status, time, rows and Mesa comparison."""

    name: str
    command: str
    rc: int | None = None
    seconds: float = 0.0
    timed_out: bool = False
    skipped: str | None = None
    result: dict | list | None = None
    parity: dict | None = None
    log_tail: str = ""
    extra: dict = field(default_factory=dict)


def _row_key(kind: str, row: dict) -> tuple:
    if kind == "tradeoff":
        return row["technique"], row["setting"], row["parameters"].get("blending")
    if kind == "resolution":
        return row["scenario"], row["technique"], tuple(row["size"])
    if kind == "voxels":
        return row["scene"], row["row"], tuple(row["size"])
    return row["shape"], row["cells"], row["row"]


def _rows(kind: str, data: dict) -> list[dict]:
    return data["results"] if kind in ("tradeoff", "voxels") else data["rows"]


def _error(kind: str, row: dict) -> float | None:
    """The row's error against the CPU reference: PSNR (dB), wrong % or IoU."""
    if kind in ("tradeoff", "resolution"):
        return None if not row.get("errors") else row["errors"]["psnr"]
    return row.get("wrong_percent") if kind == "voxels" else row.get("iou")


def _agrees(kind: str, gpu: float, mesa: float) -> bool:
    """Whether the GPU's error is as small as Mesa's, within what frame-to-frame noise moves.

    PSNR within 1 dB (or both past 60 dB), wrong pixels within 0.05 points of the image,
    IoU within 0.002.
    """
    if kind in ("tradeoff", "resolution"):
        return gpu >= mesa - 1.0 or min(gpu, mesa) >= 60.0
    if kind == "voxels":
        return gpu <= mesa + 0.05
    return gpu >= mesa - 0.002


def compare_with_mesa(kind: str, gpu: dict, mesa: dict) -> dict:
    """Match the GPU run's rows with Mesa's by setting and compare their errors.

    Returns the counts, and each matched row's two errors with whether they agree.
    """
    mesa_rows = {_row_key(kind, r): r for r in _rows(kind, mesa)}
    rows, unmatched = [], []
    for row in _rows(kind, gpu):
        key = _row_key(kind, row)
        other = mesa_rows.get(key)
        ours, theirs = _error(kind, row), None if other is None else _error(kind, other)
        if ours is None or theirs is None:
            unmatched.append(list(map(str, key)))
            continue
        rows.append({"row": list(map(str, key)), "gpu": ours, "mesa": theirs,
                     "agrees": _agrees(kind, ours, theirs)})
    return {"metric": {"tradeoff": "psnr", "resolution": "psnr", "voxels": "wrong_percent"}
            .get(kind, "iou"), "matched": len(rows),
            "disagree": sum(not r["agrees"] for r in rows), "unmatched": unmatched,
            "mesa_renderer": mesa.get("gl_renderer") or mesa.get("meta", {}).get("gl_renderer"),
            "rows": rows}


def _kind(section: Section) -> str:
    return section.args[0]


def run_section(section: Section, work: Path, limit: float) -> SectionResult:
    """Run one section as a child process within ``limit`` seconds; read its JSON back."""
    args = list(section.args)
    if section.grid is not None:
        side, writer = section.grid
        grid = work / f"{section.name}.npy"
        if not grid.exists():
            writer(grid, side)
        args = [str(grid) if a == "{grid}" else a for a in args]
    out = work / f"{section.name}.json"
    command = [sys.executable, "-m", "pv_cubemarch.cli", "bench", *args, "--json", str(out)]
    result = SectionResult(section.name, " ".join(["pv-cubemarch", "bench", *args]))
    start = time.perf_counter()
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=limit,
                              env={**os.environ, "PYTHONUNBUFFERED": "1"})
        result.rc, log = done.returncode, done.stdout + done.stderr
    except subprocess.TimeoutExpired as stopped:
        result.timed_out = True
        log = "".join(part.decode(errors="replace") if isinstance(part, bytes) else part or ""
                      for part in (stopped.stdout, stopped.stderr))
    result.seconds = time.perf_counter() - start
    result.log_tail = log[-6000:]
    if out.exists():
        result.result = json.loads(out.read_text())
        mesa = MESA_RESULTS / f"{section.mesa}.json" if section.mesa else None
        if mesa is not None and mesa.exists():
            result.parity = compare_with_mesa(_kind(section), result.result,
                                              json.loads(mesa.read_text()))
    return result


def _machine() -> dict:
    info = {"cpus": os.cpu_count(), "python": sys.version.split()[0]}
    try:
        info["nvidia_smi"] = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total",
             "--format=csv,noheader"], capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        info["nvidia_smi"] = None
    return info


def run_device_check(out: Path, plan: str = "gpu", budget: float = 420.0,
                     sections: Sequence[str] | None = None,
                     gl: Callable[[], dict] | None = None, report_path: Path | None = None
                     ) -> dict:
    """Run ``plan``'s sections in order within ``budget`` seconds; write the report.

    The report (``report_path``, by default ``out/device.json``) is rewritten after every
    section, so a run stopped from outside keeps what it measured.
    A section starts only with at least 30 s of the budget left, and is stopped at its own
    limit or the budget's end, whichever is first; its log's tail is kept either way.
    """
    if plan not in PLANS:
        raise ValueError(f"plan must be one of {sorted(PLANS)}, not {plan!r}.")
    chosen = [s for s in PLANS[plan] if sections is None or s.name in sections]
    unknown = set(sections or ()) - {s.name for s in PLANS[plan]}
    if unknown:
        raise ValueError(f"No section {sorted(unknown)} in plan {plan!r}; it has "
                         f"{[s.name for s in PLANS[plan]]}.")
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    report = {"plan": plan, "budget_s": budget, "machine": _machine(), "gl": None,
              "sections": []}
    try:
        report["gl"] = (gl or gl_info)()
    except Exception as error:   # noqa: BLE001 - the report says what failed, the plan goes on
        report["gl"] = {"error": f"{type(error).__name__}: {error}"}
    path = report_path or out / "device.json"
    for section in chosen:
        left = budget - (time.perf_counter() - start)
        if left < 30.0:
            result = SectionResult(section.name, "", skipped=f"budget spent ({left:.0f} s left)")
        else:
            result = run_section(section, out, min(section.seconds, left))
        report["sections"].append(asdict(result))
        print(_summary_line(result), flush=True)
        path.write_text(json.dumps(report, indent=1, default=str))
    report["seconds"] = time.perf_counter() - start
    path.write_text(json.dumps(report, indent=1, default=str))
    return report


def _summary_line(result: SectionResult) -> str:
    if result.skipped:
        return f"{result.name}: skipped, {result.skipped}"
    state = "timed out" if result.timed_out else f"rc {result.rc}"
    parity = ""
    if result.parity:
        parity = (f"; vs Mesa: {result.parity['matched']} rows matched, "
                  f"{result.parity['disagree']} disagree")
    return f"{result.name}: {state} in {result.seconds:.0f} s{parity}"
