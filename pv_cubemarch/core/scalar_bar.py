"""The plotter's scalar bar for what a technique colours (every kind's, in one place)."""

from __future__ import annotations


def attach_scalar_bar(plotter, actor, mapper, title: str, show: bool, args: dict | None,
                      **defaults) -> None:
    """Make ``mapper`` the plotter's (``add_scalar_bar()`` reads it); add its bar if ``show``.

    ``args`` (the user's ``scalar_bar_args``) win over the ``title``, the mapper and
    ``defaults``. The bar leaves with ``actor``, as PyVista's ``remove_actor`` takes an
    actor's bar (see :meth:`CubemarchComponent.follow_scalar_bar`).
    """
    plotter.mapper = mapper
    binding = getattr(actor, "cubemarch", None)
    if binding is not None:   # its colormap's edits (update_scalar_bar_range) are seen
        binding.bar_mapper = mapper
        look = getattr(binding, "look", None)
        if look is not None:   # actor.mapper.lookup_table: the bar's (the box draws none)
            box = actor.GetMapper()
            box.SetLookupTable(mapper.GetLookupTable())
            box.UseLookupTableScalarRangeOn()   # drawing the box leaves the bar's range
            box.SetScalarRange(mapper.GetLookupTable().GetRange())
            look.seen = look.read()
    plotter.cubemarch.follow_scalar_bar(actor, mapper, show=show, args=args)
    if show:
        options = dict(args or {})
        for key, value in dict(defaults, title=title, mapper=mapper).items():
            options.setdefault(key, value)
        plotter.add_scalar_bar(**options)


class _HeldBy:
    """What PyVista's scalar bars ask of a removed actor: its mapper."""

    def __init__(self, mapper):
        self._mapper = mapper

    def GetMapper(self):  # noqa: N802  (VTK's name, which PyVista calls)
        return self._mapper


def drop_scalar_bar_mapper(plotter, mapper) -> None:
    """Take ``mapper`` off the plotter's scalar bars; a bar left with no mapper goes.

    This is what ``remove_actor`` does for an actor's own mapper (PyVista's helper, called
    the same way); our bars' mappers are not the drawn actors' own.
    """
    plotter.scalar_bars._remove_mapper_from_plotter(_HeldBy(mapper), render=False)
