"""``bench dial``'s rows: the ladder and the default timed side by side, the front marked by
hand's rule, and each choice's own measured error."""

from __future__ import annotations

from pv_cubemarch.bench.dial import format_dial, run_dial


def test_the_dial_sweeps_the_ladder_and_the_default_and_marks_the_front(monkeypatch):
    # frame times are scripted (the last row fastest, then the ladder's order), so the
    # last row dominates the rungs it equals or beats: they must lose their star
    # catches (seen failing): each row compared with the rows before it only (a rung the
    # last, fastest row beats still starred)
    from pv_cubemarch.bench import dial

    timed = dial.time_frames_side_by_side

    def scripted(plotters, frames):   # the frames drawn, their times replaced
        timed(plotters, frames)
        return {key: [1.0 if key == len(plotters) - 1 else 2.0 + key] for key in plotters}
    monkeypatch.setattr(dial, "time_frames_side_by_side", scripted)
    sweep, dials = run_dial((96, 72), 1, ["blobs"], ["cubemap"], [30.0])
    default = [r for r in sweep if r.default]   # the rung the default equals, or its own
    assert len(default) == 1 and "face_size=" in default[0].setting
    for row in sweep:   # on the front exactly when no other row is both faster and better
        dominated = any(o.median_ms <= row.median_ms and o.psnr >= row.psnr
                        and (o.median_ms < row.median_ms or o.psnr > row.psnr) for o in sweep)
        assert row.pareto == (not dominated), row
    (dial,) = dials
    measured = next(r.psnr for r in sweep if r.setting == dial.chosen)
    assert dial.psnr == measured and dial.met == (measured >= 30.0)
    assert "<-" in format_dial(sweep, dials)
