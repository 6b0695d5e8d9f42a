"""Tables a process builds once.

Building a 3D realistic task integrates flights and runs surface quadratures: ~0.6 s for
``LightSail3DRealistic-v1``, ~1.1 s more for ``LightSailUncertain-v1``'s curvature table. Every
``gym.make`` of the same task in a process (the envs of a vector, an evaluation, a benchmark grid's
cells, the tests) needs the same tables. :func:`built_once` keeps what a factory built for each
distinct tuple of arguments (frozen configurations and numbers, hashable and compared by value) and
hands out the same object, its arrays made read-only, so that no plant can change another's tables.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

import numpy as np

#: How many distinct tables of one kind a process keeps (the least recently used goes first).
TABLES_KEPT = 16

Table = TypeVar("Table")


def built_once(factory: Callable[..., Table]) -> Callable[..., Table]:
    """``factory`` (positional, hashable arguments) called once per distinct arguments; its result shared, read-only."""

    @functools.lru_cache(maxsize=TABLES_KEPT)
    @functools.wraps(factory)
    def once(*args: object) -> Table:
        table = factory(*args)
        _make_read_only(table)
        return table

    return once


def _make_read_only(value: object, seen: set[int] | None = None) -> None:
    """Mark every NumPy array in ``value`` read-only: the arrays themselves, in lists and tuples, and in
    the attributes of this package's objects (a table's rows, a flight's table), each object once."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, (list, tuple)):
        for item in value:
            _make_read_only(item, seen)
    elif type(value).__module__.startswith("sail_env.") and hasattr(value, "__dict__"):
        for item in vars(value).values():
            _make_read_only(item, seen)
