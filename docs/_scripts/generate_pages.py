"""Pages the docs build writes from the code and the measurements, never by hand.

- ``_generated/cli.md``: every ``pv-cubemarch`` command's help, from the CLI's own parser;
- ``_generated/bench_<name>.md``: a table per measured run in ``bench_results/<name>.json``
  (what ``pv-cubemarch bench <name> --json`` writes), with the run's machine and settings;
- ``_generated/<name>.png``: error against time, for the ``bench tradeoff`` runs.

Run by ``conf.py`` at every build; ``python docs/_scripts/generate_pages.py`` runs it alone.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

#: Columns of a bench's table: (header, key path in a result row, format). A bench not
#: listed gets every scalar field of its rows, in the order the bench wrote them.
COLUMNS = {
    "resolution": [
        ("scenario", "scenario", "{}"), ("technique", "technique", "{}"),
        ("size", "size", "{}"), ("median ms", "median_ms", "{:.1f}"),
        ("PSNR dB (crops)", "errors.psnr", "{:.1f}"), ("max err", "errors.max_abs", "{:.0f}"),
        ("cube map MB", "memory.cube_map", "MB"), ("depth map MB", "memory.cube_depth_map", "MB"),
    ],
    "tradeoff": [
        ("technique", "technique", "{}"), ("blending", "parameters.blending", "{}"),
        ("setting", "setting", "{}"),
        ("median ms", "median_ms", "{:.1f}"), ("x fastest", "ratio", "{:.2f}"),
        ("PSNR dB", "errors.psnr", "{:.2f}"), ("SSIM", "errors.ssim", "{:.4f}"),
        ("max err", "errors.max_abs", "{:.0f}"), ("vs PyVista dB", "psnr_vs_pyvista", "{:.2f}"),
        ("Pareto", "pareto", "{}"),
    ],
    "labels": [
        ("scene", "scene", "{}"), ("row", "row", "{}"), ("ids", "ids", "{:,}"),
        ("setup s", "setup_s", "{:.2f}"), ("frame ms", "median_ms", "{:.1f}"),
        ("host MB", "host_bytes", "MB"), ("GPU MB", "gpu_bytes", "MB"),
        ("label B/voxel", "label_bytes_per_voxel", "{:.2f}"),
        ("wrong ids", "wrong_id_pixels", "{}"),
        ("1 id: ms", "changes.recolour 1.ms", "{:.0f}"),
        ("1 id: B", "changes.recolour 1.bytes", "{:,}"),
        ("1000: ms", "changes.recolour 1000.ms", "{:.0f}"),
        ("1000: KB", "changes.recolour 1000.bytes", "KB"),
        ("all: ms", "changes.recolour all.ms", "{:.0f}"),
        ("all: KB", "changes.recolour all.bytes", "KB"),
        ("hide half: ms", "changes.hide half.ms", "{:.0f}"),
        ("hide half: KB", "changes.hide half.bytes", "KB"),
        ("note", "note", "{}"),
    ],
    "cluster": [
        ("scene", "scene", "{}"), ("row", "row", "{}"), ("workers", "workers", "{}"),
        ("frames", "frames", "{}"), ("seconds", "seconds", "{:.2f}"), ("fps", "fps", "{:.1f}"),
        ("speed-up", "speedup", "{:.2f}"), ("efficiency", "efficiency", "{:.2f}"),
        ("+ms per frame", "overhead_ms", "{:.1f}"), ("equal to serial", "equal", "{}"),
    ],
    "sortlast": [
        ("grid", "grid", "{}"), ("row", "row", "{}"), ("slabs", "partitions", "{}"),
        ("workers", "workers", "{}"), ("frames", "frames", "{}"),
        ("s per frame", "frame_s", "{:.3f}"), ("compositing ms", "composite_ms", "{:.1f}"),
        ("sent MB per frame", "sent_mb", "{:.2f}"), ("lowest PSNR dB", "psnr_min", "{:.1f}"),
        ("wrong pixels", "wrong_pixels", "{}"), ("grazing pixels", "edge_pixels", "{}"),
    ],
    "outofcore": [
        ("scene", "scene", "{}"), ("view", "view", "{}"), ("row", "row", "{}"),
        ("first frame s", "first_frame_s", "{:.2f}"), ("converged s", "converged_s", "{:.2f}"),
        ("frames", "frames", "{}"), ("longest frame ms", "longest_frame_ms", "{:.0f}"),
        ("read MB", "bytes_read", "MB"), ("held MB", "held_brick_bytes", "MB"),
        ("peak RSS MB", "peak_rss_mb", "{:.0f}"), ("GPU MB", "gpu_mb", "{:.1f}"),
        ("PSNR dB", "psnr_db", "{:.1f}"), ("wrong %", "wrong_percent", "{:.2f}"),
        ("pool", "extra.resident", "{}"),
        ("over budget", "extra.over_budget", "{}"), ("note", "note", "{}"),
    ],
}
#: Row fields never shown: per-frame lists and the parameters already named by 'setting'.
HIDDEN = {"parameters"}


def generate_all(docs: Path) -> list[Path]:
    """Write every generated page under ``docs/_generated``; return the paths written."""
    out = docs / "_generated"
    out.mkdir(exist_ok=True)
    written = [_write(out / "cli.md", cli_markdown()),
               _write(out / "bench_commands.md", commands_markdown(docs / "bench_results"))]
    for path in sorted((docs / "bench_results").glob("*.json")):
        name = path.stem
        written.append(_write(out / f"bench_{name}.md", bench_markdown(name, path)))
        payload = json.loads(path.read_text())
        if _bench_of(payload, name) == "tradeoff":
            written.append(plot_tradeoff(payload, out / f"{name}.png"))
    return written


def _bench_of(payload: dict, name: str) -> str:
    words = payload.get("command", "").split()
    return words[words.index("bench") + 1] if "bench" in words[:-1] else name


def plot_tradeoff(payload: dict, path: Path) -> Path:
    """Error (RMS, 8-bit levels, from PSNR) against median frame time, the front joined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in payload["results"] if r["errors"]["psnr"] != float("inf")]

    def rms(row):
        return 255.0 * 10 ** (-row["errors"]["psnr"] / 20.0)

    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for technique in dict.fromkeys(r["technique"] for r in rows):
        mine = [r for r in rows if r["technique"] == technique]
        ax.scatter([r["median_ms"] for r in mine], [rms(r) for r in mine], label=technique)
    front = sorted((r for r in rows if r["pareto"]), key=lambda r: r["median_ms"])
    ax.plot([r["median_ms"] for r in front], [rms(r) for r in front], "k--", lw=0.8,
            label="Pareto front")
    ax.set_xlabel("median frame time (ms)")
    ax.set_ylabel("RMS error against the CPU reference (8-bit levels)")
    ax.set_yscale("log")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _write(path: Path, text: str) -> Path:
    # rewritten only when changed, so Sphinx does not rebuild every page each time
    if not path.exists() or path.read_text() != text:
        path.write_text(text)
    return path


def commands_markdown(results: Path) -> str:
    """The command that remakes each committed measurement, into the file the docs read."""
    lines = ["```bash"]
    for path in sorted(results.glob("*.json")):
        command = json.loads(path.read_text()).get("command", f"pv-cubemarch bench {path.stem}")
        words = [w for w in command.split()]
        if "--json" in words:
            at = words.index("--json")
            del words[at:at + 2]
        words = [w for w in words if not w.startswith("/")]
        plot = [i for i, w in enumerate(words) if w == "--plot"]
        for i in reversed(plot):
            del words[i:i + 1]
        at = next(i for i, w in enumerate(words) if "=" not in w)   # after VAR=value
        words[at] = ".venv/bin/" + words[at]
        lines.append(" ".join(words) + f" --json docs/bench_results/{path.name}")
    lines += ["bash tools/build_docs.sh", "```"]
    return "\n".join(lines) + "\n"


def cli_markdown() -> str:
    """Every command's ``--help``, walking the parser's sub-commands."""
    from pv_cubemarch.cli import build_parser

    lines = ["<!-- generated from pv_cubemarch.cli.build_parser by the docs build -->", ""]
    for name, parser in _commands(build_parser(), "pv-cubemarch"):
        lines += [f"## `{name}`", "", "```text", parser.format_help().rstrip(), "```", ""]
    return "\n".join(lines)


def _commands(parser: argparse.ArgumentParser, name: str):
    yield name, parser
    for action in parser._actions:  # argparse keeps sub-commands only here
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _commands(sub, f"{name} {sub_name}")


def bench_markdown(name: str, path: Path) -> str:
    """Markdown tables of one bench JSON, headed by what was run and where."""
    payload = json.loads(path.read_text())
    tables = _row_sets(payload)
    if not tables:
        raise ValueError(f"{path}: no rows to tabulate")
    listed = {key for key, _ in tables} | {"rows", "results", "command", "meta"}
    meta = payload.get("meta") or {k: v for k, v in payload.items() if k not in listed}
    if len(tables) == 1 and tables[0][0] is None and "results" not in payload \
            and "rows" not in payload:
        meta = {"gl_renderer": payload.get("gl_renderer", "?")}
    command = payload.get("command", f"pv-cubemarch bench {name}")
    head = [f"<!-- generated from docs/bench_results/{path.name} by the docs build -->", ""]
    described = ", ".join(f"{k}: {_plain(v)}" for k, v in meta.items()
                          if k != "frames" and
                          (not isinstance(v, (dict, list)) or k in ("size", "technique")))
    head += [f"*Measured by `{_shown_command(command)}`; {described}.*", ""]
    body = []
    for title, rows in tables:
        rows = [_labelled(_with_median(r)) for r in rows]
        if title is not None:
            body += [f"*{title.replace('_', ' ')}:*", ""]
        body += _table(rows, COLUMNS.get(_bench_of(payload, name)) or _scalar_columns(rows))
        body.append("")
    return "\n".join(head + body[:-1] + _paper_tables(payload)) + "\n"


def _row_sets(payload: dict) -> list[tuple[str | None, list[dict]]]:
    """The row lists of a bench's JSON: its results (or rows), then other lists of records.

    ``bench dial`` writes its choices and orbits beside its sweep. A bench of one
    measurement writes it as the payload itself: that is the one row.
    """
    rows = payload.get("results", payload.get("rows"))
    sets = [(None, rows)] if isinstance(rows, list) and rows else []
    sets += [(key, value) for key, value in payload.items()
             if key not in ("seed_tables", "results", "rows") and isinstance(value, list)
             and value and all(isinstance(v, dict) for v in value)]
    if sets:
        return sets
    return [(None, [{k: v for k, v in payload.items() if k not in ("command", "gl_renderer")}])]


def _table(rows: list[dict], columns) -> list[str]:
    fastest = min((r["median_ms"] for r in rows if r.get("median_ms") is not None),
                  default=None)
    table = ["| " + " | ".join(h for h, _, _ in columns) + " |",
             "|" + "---|" * len(columns)]
    for row in rows:
        cells = []
        for _, key, fmt in columns:
            if key == "ratio":
                value = (row["median_ms"] / fastest
                         if fastest and row.get("median_ms") is not None else None)
            else:
                value = _get(row, key)
            cells.append(_cell(value, fmt))
        table.append("| " + " | ".join(cells) + " |")
    return table


def _labelled(row: dict) -> dict:
    """A sweep row's setting as the technique's registration names it today."""
    from pv_cubemarch.core.registry import _REGISTRY

    technique = _REGISTRY.get(("volume", row.get("technique")))
    if technique is None or technique.sweep is None or "parameters" not in row:
        return row
    setting = {k: v for k, v in row["parameters"].items() if k != "blending"}
    try:
        return {**row, "setting": technique.sweep.describe(setting)}
    except KeyError:   # a row outside the sweep (another bench's): keep its own label
        return row


def _with_median(row: dict) -> dict:
    # benches that keep every frame's time: the median is what the tables compare
    if "median_ms" not in row and isinstance(row.get("frame_ms"), list) and row["frame_ms"]:
        times = sorted(row["frame_ms"])
        middle = len(times) // 2
        median = times[middle] if len(times) % 2 else (times[middle - 1] + times[middle]) / 2
        row = {**row, "median_ms": median}
    return row


def _paper_tables(payload: dict) -> list[str]:
    """The published speed-ups beside ours, where a bench reproduces a paper's tables."""
    tables = payload.get("seed_tables") or {}
    lines = []
    for size, rows in tables.items():
        lines += ["", f"*Speed-ups over the DDA at {size}: the paper's (its own machine) "
                  "beside ours.*", "", "| scene | row | paper | ours |", "|---|---|---|---|"]
        merged: dict[tuple, list] = {}
        for r in rows:   # a scene the paper measured in several tables: its values joined
            merged.setdefault((r["scene"], r["row"]), []).append(r)
        for (scene, row), same in merged.items():
            paper = " / ".join(dict.fromkeys(_cell(r["seed_speedup"], "{:.2f}") for r in same))
            lines.append(f"| {scene} | {row} | {paper} | "
                         f"{_cell(same[0]['our_speedup'], '{:.2f}')} |")
    return lines


def _shown_command(command: str) -> str:
    # the run's own paths (where it wrote its JSON and plot) say nothing to a reader
    words = command.split()
    return " ".join(Path(w).name if "/" in w else w for w in words)


def _scalar_columns(rows: list[dict]) -> list[tuple[str, str, str]]:
    keys: dict[str, None] = {}
    for row in rows[:1]:
        for key, value in _flatten(row):
            if isinstance(value, str):
                keys.setdefault(key)
    if any("median_ms" in row for row in rows):
        keys.setdefault("median_ms")
    for row in rows:
        for key, _value in _flatten(row):
            if key.split(".")[0] not in HIDDEN:
                keys.setdefault(key)
    columns = []
    for key in keys:
        if key.endswith("_bytes"):
            values = [v for r in rows if isinstance(v := _get(r, key), (int, float))]
            small = values and max(values) < 16 * 2**20
            columns.append((key[:-6].replace("_", " ") + (" bytes" if small else " MB"), key,
                            "{:,}" if small else "MB"))
        else:
            columns.append((key.replace("_", " "), key, "{:.1f}" if key == "median_ms" else "{}"))
    return columns


def _flatten(row: dict, prefix: str = ""):
    for key, value in row.items():
        if isinstance(value, dict):
            yield from _flatten(value, f"{prefix}{key}.")
        elif not isinstance(value, list) or _is_size(value):
            yield f"{prefix}{key}", value


def _is_size(value) -> bool:
    return isinstance(value, list) and len(value) in (2, 3) and all(
        isinstance(v, int) for v in value)


def _get(row: dict, key: str):
    for part in key.split("."):
        if not isinstance(row, dict) or part not in row:
            return None
        row = row[part]
    return row


def _cell(value, fmt: str) -> str:
    if value is None:
        return "-"
    if _is_size(value):
        return "x".join(str(v) for v in value)
    if value is True:
        return "*"
    if value is False:
        return ""
    if fmt == "MB" and not isinstance(value, (int, float)):
        return "-"
    if fmt == "MB":
        return f"{value / 2**20:.1f}"
    if fmt == "KB":
        return f"{value / 2**10:.1f}"
    if isinstance(value, float) and fmt == "{}":
        return f"{value:.4g}"
    return fmt.format(value).replace("|", "\\|")


def _plain(value) -> str:
    if isinstance(value, list):
        return "x".join(str(v) for v in value) if all(isinstance(v, int) for v in value) \
            else ", ".join(str(v) for v in value)
    text = str(value)
    return Path(text).name if text.startswith("/") else text


if __name__ == "__main__":
    for written in generate_all(Path(__file__).resolve().parents[1]):
        print("wrote", written)
