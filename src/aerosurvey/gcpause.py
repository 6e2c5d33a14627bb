"""The cyclic garbage collector paused while many objects are made that all live on."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def collector_paused() -> Iterator[None]:
    """The cyclic garbage collector off while a few hundred thousand dicts and lists are made that
    all live on (none can be garbage): each collection would walk every one of them again. Measured
    on the 100 km² benchmark (51,379 stations and as many footprints): plan_features 700 ms → 300 ms
    CPU. Switched back on only if it was on, so nested or concurrent pauses leave it as they found it."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            gc.enable()
