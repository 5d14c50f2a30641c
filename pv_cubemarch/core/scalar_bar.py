"""The plotter's scalar bar for what a technique colours (every kind's, in one place)."""

from __future__ import annotations


def attach_scalar_bar(plotter, mapper, title: str, show: bool, args: dict | None,
                      **defaults) -> None:
    """Make ``mapper`` the plotter's (``add_scalar_bar()`` reads it); add its bar if ``show``.

    ``args`` (the user's ``scalar_bar_args``) win over the ``title``, the mapper and
    ``defaults``.
    """
    plotter.mapper = mapper
    if show:
        options = dict(args or {})
        for key, value in dict(defaults, title=title, mapper=mapper).items():
            options.setdefault(key, value)
        plotter.add_scalar_bar(**options)
