"""`aerosurvey upload`: check that a plan fits the vehicle, send it over MAVLink, read it back and compare.

Exit codes: 0 uploaded and verified (or uploaded with --no-verify), 1 the link failed or the
vehicle stores something else, 2 bad input (unreadable plan, bad option), 3 refused before
anything was sent: the plan fails an error-severity rule, or it does not fit the vehicle
(autopilot, vehicle type, launch point, battery, item count; for PX4 its storage and the
commands and frames it takes) or the settings read from it (link/vehicle_settings.py), unless
--accept names the rule or the check. PX4 missions
go through MAVSDK (link/px4.py), ArduPilot missions through aerosurvey's own protocol. Nothing
is reported as uploaded unless the vehicle acknowledged every item.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import click

from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link.connection import open_link
from aerosurvey.link.upload import (
    LAUNCH_DISTANCE_M,
    VIA_PROTOCOL,
    MissionFacts,
    TransferReport,
    UploadReport,
    VerificationFailed,
    accept_names,
    check_rules,
    check_settings,
    check_vehicle,
    mission_wire_items,
    settings_to_read,
    upload_mission,
    upload_plan,
)
from aerosurvey.link.vehicle_settings import CHECKS, PlanFigures
from aerosurvey.mission.items import Mission
from aerosurvey.report.summary import RuleCount

if TYPE_CHECKING:
    from aerosurvey.manifest import Manifest

_DEFAULTS = mp.Policy()  # the command's defaults are the protocol's: one place for both


def read_mission(path: Path) -> tuple[Mission, bool]:
    """A QGroundControl .plan or a QGC WPL 110 waypoint file, told apart by its first line;
    True when it is a waypoint file (it says nothing of the vehicle type)."""
    from aerosurvey.mission.formats.qgc_plan import loads_plan
    from aerosurvey.mission.formats.wpl import loads_wpl

    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the plan: {getattr(exc, 'strerror', None) or exc}") from None
    waypoints = text.lstrip().startswith("QGC WPL")
    m = loads_wpl(text, str(path)) if waypoints else loads_plan(text, str(path))
    if not m.items:
        raise InputError(f"{path}: the plan has no mission items; there is nothing to upload")
    return m, waypoints


def _battery_words(battery: dict[str, Any]) -> str:
    """One battery of the spec, as its [battery] table says it (manifest.json's `battery`)."""
    if not battery:
        return "less than the mission needs"
    reserve = f"{battery['reserve']:.0%} kept in reserve"
    if battery.get("usable_min") is not None:
        return f"{battery['usable_min']:g} min ({reserve})"
    return f"{battery['capacity_wh']:g} Wh at {battery['cruise_power_w']:g} W cruise ({reserve})"


def mission_facts(path: Path, mission: Mission, waypoints: bool, vehicle: str | None) -> tuple[MissionFacts, str]:
    """What the checks compare with the vehicle, and the words saying where it came from.

    From the file itself (a .plan says its vehicle type, firmware and home; a `waypoints` file
    only its home, so `vehicle` must name the type), and from the manifest.json beside it when it
    lists this very file (same name and sha256): the vehicle type, the estimated time, the
    battery, the sorties and the spec's item limit. A file the manifest does not list, or lists
    with another sha256 (changed since planning), is checked on its own fields only.
    """
    from aerosurvey import manifest as mf

    own = vehicle if waypoints else mission.vehicle
    doc_path = path.parent / mf.FILE_NAME
    doc = mf.read_manifest(doc_path, "the manifest beside the plan") if doc_path.is_file() else None
    if doc is not None and doc.outputs.get(path.name) != mf.sha256_file(path):
        doc = None
    said = doc.mission.vehicle if doc is not None else own
    if said is None:
        raise InputError(f"{path.name} does not say which vehicle it is for (a .waypoints file has no vehicle type and no "
                         "manifest.json beside it lists it): give --vehicle copter or --vehicle plane, or upload the .plan",
                         key="--vehicle")
    if vehicle is not None and vehicle != said:
        raise InputError(f"--vehicle {vehicle}: {path.name} is a {said} mission", key="--vehicle")
    launch, items = (mission.home[0], mission.home[1]), len(mission_wire_items(mission))
    if doc is None:
        why = "no manifest.json beside it" if not doc_path.is_file() else f"{mf.FILE_NAME} does not list this file as it is"
        return (MissionFacts(path.name, said, mission.firmware, launch, items),
                f"checked on its own fields ({why}): battery and sorties not compared")
    battery = doc.raw.get("battery") or {}
    sortie = next((s for s in doc.sorties if path.name in s.files), None)
    if sortie is None:  # the whole mission
        est = doc.estimates.get("total_time_s")
        sorties = tuple(f for s in doc.sorties for f in s.files if f.endswith(path.suffix)) if len(doc.sorties) > 1 else ()
    else:
        est, sorties = sortie.time_s, ()
    rules = RuleCount.of(doc.rules)
    return (MissionFacts(path.name, said, mission.firmware, launch, items, battery.get("max_mission_items"),
                         None if est is None else est / 60.0, _battery_words(battery), sorties, plan_figures(doc),
                         tuple(r["rule"] for r in doc.rules), rules.failed),
            f"checked against {mf.FILE_NAME} ({'the whole mission' if sortie is None else 'sortie ' + sortie.id})")


def plan_figures(doc: Manifest) -> PlanFigures:
    """What the vehicle's settings are compared with, from the manifest: the battery's reserve, the
    highest ground under the plan above the launch point (its DEM figures), and the official zones
    near the flights that restrict them (its airspace record; None when the plan was checked against none)."""
    reserve = (doc.raw.get("battery") or {}).get("reserve")
    ground_max = doc.raw["derived"]["terrain"].get("ground_max_m")
    home = doc.home.ground_amsl_m
    airspace = doc.raw.get("airspace")
    zones = None if airspace is None else tuple(
        z["name"] or z["identifier"] for z in airspace["zones"] if z["restriction"] != "NO_RESTRICTION")
    return PlanFigures(reserve, None if ground_max is None or home is None else ground_max - home, zones)


def _launch_distance(value: str) -> float | None:
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


_ITEM_WORDS = {mp.MISSION: "mission items", mp.FENCE: "fence vertices", mp.RALLY: "rally points"}


def _stats(s: mp.Stats) -> str:
    lost = "; the vehicle's final MISSION_ACK was lost, the read-back below proves the upload" if s.ack_lost else ""
    return f"{s.resends} resend(s), {s.restarts} restart(s), {s.duplicate_requests} repeated request(s){lost}"


def format_report(r: UploadReport, verified: bool, rally_asked: bool = False) -> list[str]:
    v = r.vehicle
    lines = [f"vehicle: system {v.system}, component {v.component}, {v.autopilot_name}, MAV_TYPE {v.mav_type}"]
    if r.via != VIA_PROTOCOL:
        lines.append(f"transfers: through {r.via}")

    def cost(t: TransferReport) -> str:
        if r.via == VIA_PROTOCOL:
            return _stats(t.stats)
        lost = ("; MAVSDK timed out waiting for the vehicle's final MISSION_ACK, the read-back below proves the upload"
                if t.stats.ack_lost else "")
        return "MAVSDK does not report resends" + lost

    m = r.mission
    lines.append(f"mission: {m.items} items uploaded in {m.seconds:.2f} s ({cost(m)})")
    if r.fence is not None:
        lines.append(f"fence: {r.fence.items} vertices uploaded in {r.fence.seconds:.2f} s ({cost(r.fence)})")
    else:
        lines.append("fence: none in the plan; the vehicle's fence was left as it was")
    if r.rally is not None:
        lines.append(f"rally: {r.rally.items} points uploaded in {r.rally.seconds:.2f} s ({cost(r.rally)})")
    elif rally_asked:
        lines.append("rally: none in the plan; the vehicle's rally points were left as they were")
    if not verified:
        lines.append("not verified (--no-verify): the vehicle acknowledged every item, nothing was read back")
        return lines
    counts = [f"{t.items} {_ITEM_WORDS[t.mission_type]}" for t in r.transfers]
    what = ", ".join(counts[:-1]) + (" and " if len(counts) > 1 else "") + counts[-1]
    lines.append(f"verified: {what} read back and compared {r.compared_as}; all match")
    if r.home_note:
        lines.append(r.home_note)
    return lines


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
@click.option("--accept", "accept", multiple=True, metavar="NAME",
              help=f"Upload although the named check refuses ({', '.join(CHECKS)}), or although the plan fails the named "
                   "error-severity rule; repeatable, one name each. The report says what was accepted.")
def upload(plan_file: Path, url: str, timeout: float, retries: int, vehicle: str | None, launch_distance: str,
           no_verify: bool, autopilot: str | None, rally: bool, accept: tuple[str, ...]) -> None:
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
    """
    mission, waypoints = read_mission(plan_file)
    if autopilot is not None and autopilot != mission.firmware:
        raise InputError(f"--autopilot {autopilot}: {plan_file.name} is a mission for {mission.firmware}; plan it for "
                         f"{autopilot} and upload that", key="--autopilot")
    limit = _launch_distance(launch_distance)
    facts, source = mission_facts(plan_file, mission, waypoints, vehicle)
    accepted = accept_names(facts, accept)
    rules = check_rules(facts, accepted)
    policy = mp.Policy(timeout=timeout, retries=retries)
    if mission.firmware == "px4":
        from aerosurvey.link.px4 import MavsdkTransfers, mavsdk_url
        from aerosurvey.link.upload import check_px4

        mavsdk_url(url)  # a connection MAVSDK cannot open is bad input before anything else
    try:
        with open_link(url, policy.silence) as link:
            assert link.vehicle is not None
            position = link.vehicle_position(policy.silence) if limit is not None else None
            where = check_vehicle(facts, link.vehicle, position, limit)
            if mission.firmware == "px4":
                check_px4(mission, facts.file, rally)
            params = link.read_params(settings_to_read(facts, link.vehicle), policy.silence)
            settings = check_settings(facts, mission, link.vehicle, params, accepted)
            if mission.firmware != "px4":
                with TransferProgress(sys.stderr) as progress:
                    report = upload_mission(link, mission, policy, verify=not no_verify, progress=progress, rally=rally)
        if mission.firmware == "px4":  # the checks' link is closed: MAVSDK opens the same connection
            with MavsdkTransfers(url, link.vehicle, policy.timeout, policy.silence, not no_verify) as transfers:
                report = upload_plan(transfers, mission, verify=not no_verify, rally=rally)
    except VerificationFailed as exc:
        for mm in exc.mismatches[:20]:
            click.echo(f"  differs: {mm}", err=True)
        if len(exc.mismatches) > 20:
            click.echo(f"  ... {len(exc.mismatches) - 20} more", err=True)
        raise
    click.echo(f"{facts.file}: {facts.vehicle} mission for {facts.firmware}, {source}")
    click.echo(where)
    click.echo(rules)
    for line in settings:
        click.echo(line)
    for line in format_report(report, not no_verify, rally):
        click.echo(line)
    if mission.rally and not rally:
        click.echo(f"note: the plan's {len(mission.rally)} rally point(s) were not uploaded; give --rally to upload them")
