"""What commands show on stderr besides their results: log messages and progress.

Logging: `configure_logging(verbosity)` (called by the `aerosurvey` group from its `-v`/`-q`
options) sends every log record at or above the chosen level to stderr as one line,
``warning: …``. Commands and library modules log through `logging.getLogger(__name__)`;
results go to stdout with `click.echo`, a command's report of what it did (a summary) with
`echo`, which -q silences.

Progress: `progress(label)` is a context manager that yields a report callable with the
planner's `Progress` signature, ``report(stage: str, done: float)``. On a terminal it draws
a transient progress bar on stderr; in a pipe, or with `-q`, it draws nothing (stage
changes are logged at debug level). Rich loads only when a bar is drawn.

This module is on every command's start-up path: it imports nothing heavy at module level.
"""

from __future__ import annotations

import contextlib
import logging
import sys
from collections.abc import Callable, Iterator
from typing import IO

import click

#: The report callable: a stage name and the share of the whole work done, 0..1. It is the
#: planner's `aerosurvey.plan.planner.Progress`; it may be passed wherever that is taken.
Report = Callable[[str, float], None]

_log = logging.getLogger(__name__)
_state = {"verbosity": 0}


class _StderrHandler(logging.Handler):
    """One line per record on the current stderr (looked up per record, so click's test runner sees it)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            click.echo(self.format(record), err=True)
        except Exception:  # logging must never break a command
            self.handleError(record)


class _Formatter(logging.Formatter):
    def format(self, record: logging.LogRecord) -> str:
        text = record.getMessage()
        if record.exc_info:  # logged with a traceback: a defect, whose traceback is its report
            text += "\n" + self.formatException(record.exc_info)
        where = f"{record.name}: " if record.levelno <= logging.DEBUG else ""
        return f"{record.levelname.lower()}: {where}{text}"


def level_for(verbosity: int) -> int:
    """Log level of a verbosity (count of -v minus count of -q): 0 warning, 1 info, 2 debug, -1 error, -2 critical."""
    return max(logging.DEBUG, min(logging.CRITICAL, logging.WARNING - 10 * verbosity))


def configure_logging(verbosity: int = 0) -> None:
    """Log records at the verbosity's level (see `level_for`) and above to stderr, one line each.

    Replaces the handler an earlier call installed, so it may be called once per command run
    (click's test runner runs many in one process).
    """
    _state["verbosity"] = verbosity
    root = logging.getLogger()
    for h in [h for h in root.handlers if isinstance(h, _StderrHandler)]:
        root.removeHandler(h)
    handler = _StderrHandler()
    handler.setFormatter(_Formatter())
    root.addHandler(handler)
    root.setLevel(level_for(verbosity))


def quiet() -> bool:
    """Whether the user asked for quiet (-q): no progress is drawn then."""
    return _state["verbosity"] < 0


def echo(text: str) -> None:
    """A line of a command's report on stdout (what `plan` planned, what `check` found): left
    out with -q, which leaves errors only. The exit code still tells how it went."""
    if not quiet():
        click.echo(text)


def part(report: Report, start: float, end: float) -> Report:
    """A report for one part of a job that runs from `start` to `end` of the whole:
    `part(report, 0.0, 0.9)` passes a planner's 0..1 on as 0..0.9."""

    def scaled(stage: str, done: float) -> None:
        report(stage, start + (end - start) * min(1.0, max(0.0, done)))

    return scaled


@contextlib.contextmanager
def progress(label: str, *, enabled: bool | None = None, file: IO[str] | None = None) -> Iterator[Report]:
    """Report the progress of a long job on stderr while the block runs.

    In a command::

        from aerosurvey import console

        with console.progress("planning") as report:
            plan = plan_mission(spec, console.part(report, 0.0, 0.9))
            report("writing the mission files", 0.9)
            write_outputs(plan, spec, outdir)

    `report(stage, done)` names the current stage and the share of the whole job done (0..1;
    values outside are clamped, a smaller value than before does not move the bar back). A
    library function takes it as a plain `Callable[[str, float], None]` parameter and calls it
    between its steps; it knows nothing of terminals. The bar disappears when the block ends.

    `enabled` None (the default) draws the bar when `file` (default stderr) is a terminal and
    the user did not ask for quiet; True or False decides it (tests). Without a bar, the
    report only logs each new stage at debug level (seen with -vv).
    """
    stream = file if file is not None else sys.stderr
    if enabled is None:
        enabled = not quiet() and _isatty(stream)
    last = {"stage": ""}

    def log_stage(stage: str) -> None:
        if stage != last["stage"]:
            last["stage"] = stage
            _log.debug("%s: %s", label, stage)

    if not enabled:

        def silent(stage: str, done: float) -> None:
            log_stage(stage)

        yield silent
        return

    from rich.console import Console  # heavy-ish: loads only when a bar is drawn
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn

    # log lines written to stderr while the bar is drawn go above it (redirect_stderr); stdout is
    # the command's results and is never drawn through the bar's console
    bar = Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                   console=Console(file=stream, force_terminal=True if file is not None else None), transient=True,
                   redirect_stdout=False, redirect_stderr=file is None)
    task = bar.add_task(label, total=1.0)
    shown = {"done": 0.0}

    def draw(stage: str, done: float) -> None:
        log_stage(stage)
        shown["done"] = max(shown["done"], min(1.0, max(0.0, done)))
        bar.update(task, completed=shown["done"], description=f"{label}: {stage}")

    with bar:
        yield draw


def _isatty(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):  # closed or file-like without a terminal
        return False
