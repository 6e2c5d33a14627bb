"""`aerosurvey upload`: send a plan to a vehicle over MAVLink, read it back and compare.

Exit codes: 0 uploaded and verified (or uploaded with --no-verify), 1 the link failed or the
vehicle stores something else, 2 bad input (unreadable plan, bad option, wrong firmware).
Nothing is reported as uploaded unless the vehicle acknowledged every item.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import click

from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.connection import open_link
from aerosurvey.link.upload import UploadReport, VerificationFailed, upload_mission
from aerosurvey.mission.items import Mission


def read_mission(path: Path) -> Mission:
    """A QGroundControl .plan or a QGC WPL 110 waypoint file, told apart by its first line."""
    from aerosurvey.mission.formats.qgc_plan import loads_plan
    from aerosurvey.mission.formats.wpl import loads_wpl

    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the plan: {getattr(exc, 'strerror', None) or exc}") from None
    m = loads_wpl(text, str(path)) if text.lstrip().startswith("QGC WPL") else loads_plan(text, str(path))
    if not m.items:
        raise InputError(f"{path}: the plan has no mission items; there is nothing to upload")
    if m.rally:
        click.echo(f"note: the plan's {len(m.rally)} rally point(s) are not uploaded (aerosurvey uploads the mission "
                   "and the fence); upload them with QGroundControl or Mission Planner", err=True)
    return m


class TransferProgress:
    """Progress bars for the transfers of one upload on `stream` (stderr), drawn with rich.

    Shown only when `stream` is a terminal and only once `delay` seconds have passed since it
    was made, so quick uploads and output into pipes or logs stay exactly as they were.
    Call it as `progress(what, done, total)`; `close` (or leaving the `with`) removes the bars.
    """

    def __init__(self, stream: TextIO, delay: float = 1.0, clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.enabled = stream.isatty()
        self.delay = delay
        self.clock = clock
        self.t0 = clock()
        self._bars: Any = None
        self._tasks: dict[str, Any] = {}

    def __enter__(self) -> TransferProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __call__(self, what: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self._bars is None:
            if self.clock() - self.t0 < self.delay:
                return
            # imported only when bars are shown: this module is on the CLI's start-up path
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._bars = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                                  console=Console(file=self.stream, force_terminal=True), transient=True)
            self._bars.start()
        task = self._tasks.get(what)
        if task is None:
            task = self._tasks[what] = self._bars.add_task(what, total=total or None)
        self._bars.update(task, completed=done, total=total or None)

    def close(self) -> None:
        if self._bars is not None:
            self._bars.stop()
            self._bars = None


def _stats(s: mp.Stats) -> str:
    lost = "; the vehicle's final MISSION_ACK was lost, the read-back below proves the upload" if s.ack_lost else ""
    return f"{s.resends} resend(s), {s.restarts} restart(s), {s.duplicate_requests} repeated request(s){lost}"


def format_report(r: UploadReport, verified: bool) -> list[str]:
    v = r.vehicle
    lines = [f"vehicle: system {v.system}, component {v.component}, {v.autopilot_name}, MAV_TYPE {v.mav_type}"]
    m = r.mission
    lines.append(f"mission: {m.items} items uploaded in {m.seconds:.2f} s ({_stats(m.stats)})")
    if r.fence is not None:
        lines.append(f"fence: {r.fence.items} vertices uploaded in {r.fence.seconds:.2f} s ({_stats(r.fence.stats)})")
    else:
        lines.append("fence: none in the plan; the vehicle's fence was left as it was")
    if not verified:
        lines.append("not verified (--no-verify): the vehicle acknowledged every item, nothing was read back")
        return lines
    what = f"{m.items} mission items" + (f" and {r.fence.items} fence vertices" if r.fence is not None else "")
    lines.append(f"verified: {what} read back and compared {r.compared_as}; all match")
    if r.home_note:
        lines.append(r.home_note)
    return lines


@click.command()
@click.argument("plan_file", type=click.Path(path_type=Path))
@click.option("--connect", "url", required=True,
              help="pymavlink connection string, e.g. tcp:127.0.0.1:5760, udpin:0.0.0.0:14550, /dev/ttyACM0.")
@click.option("--timeout", type=click.FloatRange(min=0.01), default=1.0, show_default=True,
              help="Seconds to wait for an answer before a resend. Silence for timeout x (retries + 1) "
                   "ends the wait for the heartbeat or for a protocol step.")
@click.option("--retries", type=click.IntRange(min=0), default=5, show_default=True,
              help="Resends of one protocol step before the transaction is restarted or given up.")
@click.option("--no-verify", is_flag=True, help="Do not read the mission back and compare it.")
def upload(plan_file: Path, url: str, timeout: float, retries: int, no_verify: bool) -> None:
    """Upload PLAN_FILE (.plan or .waypoints) to a vehicle, with its fence, then read it back and compare.

    Exit code 0 when uploaded and verified, 1 when the link fails or the vehicle stores
    something else (the differing item, field and values are named; a partial mission is
    "the vehicle holds N of M mission items: do not fly it"), 2 for bad input. Progress goes
    to stderr when it is a terminal and the upload takes more than a second.
    """
    mission = read_mission(plan_file)
    policy = mp.Policy(timeout=timeout, retries=retries)
    with open_link(url, timeout * (retries + 1)) as link:
        try:
            with TransferProgress(sys.stderr) as progress:
                report = upload_mission(link, mission, policy, verify=not no_verify, progress=progress)
        except VerificationFailed as exc:
            for mm in exc.mismatches[:20]:
                click.echo(f"  differs: {mm}", err=True)
            if len(exc.mismatches) > 20:
                click.echo(f"  ... {len(exc.mismatches) - 20} more", err=True)
            raise
    for line in format_report(report, not no_verify):
        click.echo(line)
