"""`aerosurvey upload`: check that a plan fits the vehicle, send it over MAVLink, read it back and compare.

Exit codes: 0 uploaded and verified (or uploaded with --no-verify), 1 the link failed or the
vehicle stores something else, 2 bad input (unreadable plan, bad option), 3 refused before
anything was sent: the plan fails an error-severity rule, or it does not fit the vehicle
(autopilot, vehicle type, launch point, battery, item count; for PX4 its storage and the
commands and frames it takes) or the settings read from it (link/vehicle_settings.py), or with
--zones an official zone that blocks the flight, unless --accept names the rule or the check. PX4
missions go through MAVSDK (link/px4.py), ArduPilot missions through aerosurvey's own protocol.
Nothing is reported as uploaded unless the vehicle acknowledged every item. The logic is the
library's (link/preflight.py, shared with `brief --connect` and the page); this module parses the
options and prints.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import click

from aerosurvey.commands.brief import flight_start
from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.preflight import AIRSPACE, Prepared, outcome_lines, prepare, run_upload
from aerosurvey.link.upload import LAUNCH_DISTANCE_M, UploadReport, VerificationFailed
from aerosurvey.link.vehicle_settings import CHECKS

_DEFAULTS = mp.Policy()  # the command's defaults are the protocol's: one place for both


def launch_distance_limit(value: str) -> float | None:
    if value.strip().lower() == "off":
        return None
    try:
        d = float(value)
    except ValueError:
        d = math.nan
    if not (d >= 0 and math.isfinite(d)):
        from aerosurvey.errors import bad_value

        raise bad_value("--launch-distance", value, "a distance in metres (0 or more), or off")
    return d


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


@click.command()
@click.argument("plan_file", type=click.Path(path_type=Path))
@click.option("--connect", "url", required=True,
              help="pymavlink connection string, e.g. tcp:127.0.0.1:5760, udpin:0.0.0.0:14550, /dev/ttyACM0.")
@click.option("--timeout", type=click.FloatRange(min=_DEFAULTS.min_timeout), default=_DEFAULTS.timeout, show_default=True,
              help="The longest wait for an answer before a resend; below it the wait follows the round trips "
                   "measured on the link. Silence for timeout x (retries + 1) ends the wait for the heartbeat or "
                   "restarts a transfer.")
@click.option("--retries", type=click.IntRange(min=0), default=_DEFAULTS.retries, show_default=True,
              help="See --timeout: how many timeouts of silence end a step.")
@click.option("--vehicle", type=click.Choice(["copter", "plane"]), default=None,
              help="The vehicle type a .waypoints file without its manifest.json is for (a .plan says it itself).")
@click.option("--launch-distance", "launch_distance", default=f"{LAUNCH_DISTANCE_M:g}", show_default=True,
              help="The farthest (m) the vehicle may be from the planned launch point; a larger value confirms "
                   "that it is that far. 'off': do not compare (e.g. no GPS fix on the bench).")
@click.option("--no-verify", is_flag=True, help="Do not read the mission back and compare it.")
@click.option("--autopilot", type=click.Choice(["ardupilot", "px4"]), default=None,
              help="The autopilot the vehicle runs (default: the one the plan is for). ArduPilot missions go through "
                   "aerosurvey's mission protocol, PX4 missions through MAVSDK's mission_raw plugin.")
@click.option("--rally", is_flag=True, help="Upload the plan's rally points too (MAV_MISSION_TYPE_RALLY), and verify them.")
@click.option("--zones", "zone_files", multiple=True, type=click.Path(dir_okay=False, path_type=Path),
              help="An official UAS zone file (ED-269 or ED-318; repeatable) besides the spec's [airspace] zones: the "
                   "plan is made again from its spec for the flight from now, and every leg of the uploaded flight, "
                   "its return at the vehicle's RTL altitude included, is checked against them (docs/upload.md).")
@click.option("--at", "at", default=None,
              help="With --zones: when the flight starts, ISO 8601 with its UTC offset (default: now).")
@click.option("--accept", "accept", multiple=True, metavar="NAME",
              help=f"Upload although the named check refuses ({', '.join(CHECKS)}, {AIRSPACE} with --zones), or although "
                   "the plan fails the named error-severity rule; repeatable, one name each. The report says what was "
                   "accepted.")
def upload(plan_file: Path, url: str, timeout: float, retries: int, vehicle: str | None, launch_distance: str,
           no_verify: bool, autopilot: str | None, rally: bool, zone_files: tuple[Path, ...], at: str | None,
           accept: tuple[str, ...]) -> None:
    """Upload PLAN_FILE (.plan or .waypoints) to a vehicle, with its fence, then read it back and compare.

    With --rally its rally points go too. PX4 missions go through MAVSDK's mission_raw plugin.

    Before sending anything it refuses, with exit code 3, a plan that fails an error-severity rule
    (unless --accept names each such rule), and compares the vehicle with the mission: autopilot,
    vehicle type, distance from the planned launch point, battery, item count, for PX4 its storage
    and the commands and frames it takes, and the settings the mission depends on, read from it
    (terrain, camera, RTL altitude, speed limit, battery failsafe, PX4's MIS_DIST_WPS: docs/upload.md);
    --accept NAME overrides one named check. Exit code 0
    when uploaded and verified, 1 when the link fails or the vehicle stores something else (the
    differing item, field and values are named; a partial mission is "the vehicle holds N of M
    mission items: do not fly it"), 2 for bad input. Progress goes to stderr when it is a
    terminal and the upload takes more than a second.

    A PLAN_FILE in a campaign block's folder records an "uploaded" event in the campaign's
    register once uploaded (docs/campaign.md).
    """
    limit = launch_distance_limit(launch_distance)
    if at is not None and not zone_files:
        raise InputError(f"--at {at}: the time a flight starts is used by --zones only; give the zone files too", key="--at")
    prep = prepare(plan_file, vehicle, autopilot, accept, zone_files, flight_start(at) if zone_files else None)
    try:
        with TransferProgress(sys.stderr) as progress:
            out = run_upload(url, prep, mp.Policy(timeout=timeout, retries=retries), limit, verify=not no_verify,
                             rally=rally, progress=progress)
    except VerificationFailed as exc:
        for mm in exc.mismatches[:20]:
            click.echo(f"  differs: {mm}", err=True)
        if len(exc.mismatches) > 20:
            click.echo(f"  ... {len(exc.mismatches) - 20} more", err=True)
        raise
    for line in outcome_lines(prep, out, not no_verify, rally):
        click.echo(line)
    if out.report is not None:  # uploaded (send is on): a campaign block's folder records it
        from aerosurvey.commands.block_events import record_block_event

        record_block_event(plan_file.parent, "uploaded", uploaded_detail(plan_file, prep, out.report, not no_verify))


def uploaded_detail(plan_file: Path, prep: Prepared, r: UploadReport, verified: bool) -> str:
    """The "uploaded" event's detail: the file, the mission, the items sent, the vehicle, verified or not."""
    sent = "".join(f", {t.items} {what}" for what, t in (("fence vertices", r.fence), ("rally points", r.rally))
                   if t is not None)
    return (f"{plan_file.name}: {prep.facts.vehicle} mission for {prep.facts.firmware}, {r.mission.items} mission items"
            f"{sent} to system {r.vehicle.system} ({r.vehicle.autopilot_name}); "
            + ("verified (read back and compared)" if verified else "not verified (--no-verify)"))
