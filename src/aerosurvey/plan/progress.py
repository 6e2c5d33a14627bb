"""The progress hook every planning step may call."""

from __future__ import annotations

from collections.abc import Callable

#: Called with a stage name and the share of the work done (0..1). It may raise to stop the
#: planning (a web page cancelling a long plan does); the exception passes through unchanged.
Progress = Callable[[str, float], None]


def no_progress(stage: str, done: float) -> None:
    return None
