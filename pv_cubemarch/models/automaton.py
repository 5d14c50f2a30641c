"""3D cellular automata: ``survival/birth/states/neighbourhood`` rules, in numpy.

A cell's state is 0 (dead), ``states - 1`` (alive) or in between (dying: one less each
step until 0). Each step counts every cell's alive neighbours (Moore: the 26 around it;
von Neumann: the 6 sharing a face); an alive cell stays alive if the count is in
``survival``, else starts dying; a dead cell is born (alive) if the count is in ``birth``;
dying cells neither count nor are born again until dead. Cells outside the grid are dead,
or the grid wraps around (``wrap=True``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

NEIGHBOURHOODS = {"M": "moore", "VN": "von_neumann", "N": "von_neumann"}
#: Rules from the usual catalogue (survival/birth/states/neighbours).
PRESETS = {
    "445": "4/4/5/M",
    "clouds": "13-26/13-14,17-19/2/M",
    "pyroclastic": "4-7/6-8/10/M",
    "amoeba": "9-26/5-7,12-13,15/5/M",
    "builder": "2,6,9/4,6,8-9/10/M",
    "crystal": "0-6/1,3/2/VN",
}
COLORINGS = ("state", "density", "distance", "position")


def _counts(text: str, most: int) -> frozenset[int]:
    """``"4-7,9"`` as the set {4, 5, 6, 7, 9}; empty text: no count."""
    values: set[int] = set()
    for part in filter(None, text.split(",")):
        match = re.fullmatch(r"(\d+)(?:-(\d+))?", part.strip())
        if match is None:
            raise ValueError(f"{part!r} is not a count or a range of counts (e.g. 4-7).")
        low, high = int(match[1]), int(match[2] or match[1])
        if not 0 <= low <= high <= most:
            raise ValueError(f"counts must be in 0..{most}, got {part!r}.")
        values.update(range(low, high + 1))
    return frozenset(values)


@dataclass(frozen=True)
class AutomatonRule:
    """A rule: the alive-neighbour counts that keep a cell alive or give birth.

    ``survival`` and ``birth`` are sets of counts; ``states`` counts dead, dying and alive
    (2: alive or dead); ``neighbourhood`` is ``'moore'`` or ``'von_neumann'``.
    """

    survival: frozenset[int]
    birth: frozenset[int]
    states: int
    neighbourhood: str = "moore"

    @classmethod
    def parse(cls, rule: str) -> AutomatonRule:
        """A rule as ``"survival/birth/states/M"`` (or ``/VN``), or a :data:`PRESETS` name."""
        text = PRESETS.get(str(rule).lower(), str(rule))
        parts = text.split("/")
        if len(parts) != 4 or parts[3].strip().upper() not in NEIGHBOURHOODS:
            raise ValueError(f"rule must look like '4/4/5/M' (survival/birth/states/M or VN) "
                             f"or be one of {sorted(PRESETS)}, got {rule!r}.")
        neighbourhood = NEIGHBOURHOODS[parts[3].strip().upper()]
        most = 26 if neighbourhood == "moore" else 6
        if not parts[2].strip().isdigit() or int(parts[2]) < 2:
            raise ValueError(f"states must be a whole number of at least 2, got {parts[2]!r} "
                             f"in {rule!r}.")
        return cls(_counts(parts[0], most), _counts(parts[1], most), int(parts[2]),
                   neighbourhood)


def count_neighbours(alive: np.ndarray, neighbourhood: str = "moore",
                     wrap: bool = False) -> np.ndarray:
    """Per cell, how many of its neighbours are ``alive`` (uint8)."""
    alive = np.asarray(alive, dtype=np.uint8)
    if neighbourhood not in ("moore", "von_neumann"):
        raise ValueError(f"neighbourhood must be 'moore' or 'von_neumann', got "
                         f"{neighbourhood!r}.")
    padded = np.pad(alive, 1, mode="wrap" if wrap else "constant")
    core = tuple(slice(1, -1) for _ in range(3))
    if neighbourhood == "von_neumann":
        total = np.zeros(alive.shape, np.uint8)
        for axis in range(3):
            for start in (0, 2):
                window = list(core)
                window[axis] = slice(start, start + alive.shape[axis])
                total += padded[tuple(window)]
        return total
    # Moore: the 3x3x3 box sum (separable: three passes of three), minus the cell itself.
    total = padded
    for axis in range(3):
        n = total.shape[axis] - 2
        parts = [np.take(total, range(k, k + n), axis=axis) for k in range(3)]
        total = parts[0] + parts[1] + parts[2]
    return (total - alive).astype(np.uint8)


class VoxelAutomaton:
    """A 3D cellular automaton on a grid, stepped in numpy; its cells as material labels.

    Parameters
    ----------
    dimensions : sequence of int
        Cells along x, y, z.
    rule : str or AutomatonRule
        ``"survival/birth/states/M"`` (Moore) or ``.../VN`` (von Neumann), e.g.
        ``"4/4/5/M"``, or a name of :data:`PRESETS` (``"clouds"``, ``"pyroclastic"`` ...).
    seed : int
        Seed of the random start.
    start_size : float
        Edge of the centred cube seeded at random, as a share of the grid (0-1).
    start_density : float
        Share of that cube's cells alive at the start.
    wrap : bool
        Whether the grid wraps around (else cells outside are dead).

    Examples
    --------
    >>> from pv_cubemarch.models.automaton import VoxelAutomaton
    >>> automaton = VoxelAutomaton((64, 64, 64), rule="pyroclastic", seed=1)
    >>> changed = automaton.step()
    >>> labels = automaton.labels("state")   # for add_voxels, 0 = empty
    """

    def __init__(self, dimensions: Sequence[int], rule: str | AutomatonRule = "445",
                 seed: int = 0, start_size: float = 0.3, start_density: float = 0.5,
                 wrap: bool = False):
        dims = tuple(int(n) for n in dimensions)
        if len(dims) != 3 or min(dims) < 1:
            raise ValueError(f"dimensions must be three positive sizes, got {dimensions!r}.")
        if not (0.0 < float(start_size) <= 1.0 and 0.0 <= float(start_density) <= 1.0):
            raise ValueError("start_size must be in (0, 1] and start_density in [0, 1].")
        self.rule = rule if isinstance(rule, AutomatonRule) else AutomatonRule.parse(rule)
        if self.rule.states > 255:
            raise ValueError(f"at most 255 states fit a uint8 grid, got {self.rule.states}.")
        self.wrap = bool(wrap)
        self.steps = 0
        rng = np.random.default_rng(seed)
        self.state = np.zeros(dims, np.uint8)
        half = [max(1, round(n * float(start_size) / 2)) for n in dims]
        cube = tuple(slice(max(0, n // 2 - h), min(n, n // 2 + h))
                     for n, h in zip(dims, half, strict=True))
        shape = self.state[cube].shape
        self.state[cube] = np.where(rng.random(shape) < float(start_density),
                                    self.rule.states - 1, 0)
        self._survive = np.isin(np.arange(27), sorted(self.rule.survival))
        self._birth = np.isin(np.arange(27), sorted(self.rule.birth))

    @property
    def alive(self) -> np.ndarray:
        """Where cells are alive (the state ``states - 1``)."""
        return self.state == self.rule.states - 1

    def step(self) -> tuple[slice, slice, slice] | None:
        """Advance one step; returns the box of cells that changed (``None``: none did)."""
        top = self.rule.states - 1
        alive = self.state == top
        counts = count_neighbours(alive, self.rule.neighbourhood, self.wrap)
        born = (self.state == 0) & self._birth[counts]
        fading = (self.state > 0) & ~(alive & self._survive[counts])
        new = self.state.copy()
        new[fading] -= 1
        new[born] = top
        changed = new != self.state
        self.state = new
        self.steps += 1
        if not changed.any():
            return None
        box = []
        for axis in range(3):
            along = np.flatnonzero(changed.any(axis=tuple(a for a in range(3) if a != axis)))
            box.append(slice(int(along[0]), int(along[-1]) + 1))
        return tuple(box)

    def labels(self, color_by: str = "state", buckets: int = 16) -> np.ndarray:
        """The cells as labels (uint8, 0 = dead) coloured ``color_by``.

        ``'state'``: the state (1..states-1); ``'density'``: 1 + the alive neighbours;
        ``'distance'``: 1 + the distance from the grid's centre in ``buckets`` steps;
        ``'position'``: 1 + the position along the grid's diagonal in ``buckets`` steps.
        """
        if color_by not in COLORINGS:
            raise ValueError(f"color_by must be one of {COLORINGS}, got {color_by!r}.")
        if not 1 <= int(buckets) <= 254:
            raise ValueError(f"buckets must be in 1..254 (labels 1..buckets), got {buckets!r}.")
        filled = self.state > 0
        if color_by == "state":
            return self.state.copy()
        if color_by == "density":
            value = count_neighbours(self.alive, self.rule.neighbourhood, self.wrap) + 1
            return np.where(filled, value, 0).astype(np.uint8)
        dims = np.array(self.state.shape, dtype=np.float64)
        x, y, z = np.ogrid[:self.state.shape[0], :self.state.shape[1], :self.state.shape[2]]
        if color_by == "distance":
            share = np.sqrt(((x + 0.5) / dims[0] - 0.5) ** 2 + ((y + 0.5) / dims[1] - 0.5) ** 2
                            + ((z + 0.5) / dims[2] - 0.5) ** 2) / np.sqrt(0.75)
        else:
            share = ((x + 0.5) / dims[0] + (y + 0.5) / dims[1] + (z + 0.5) / dims[2]) / 3.0
        value = 1 + np.minimum((share * buckets).astype(int), buckets - 1)
        return np.where(filled, value, 0).astype(np.uint8)
