"""An upload from start to end, for every caller (`aerosurvey upload`, `brief --connect`, the page):
the plan file read and what the checks compare (its manifest, its official zones), the vehicle
connected and checked, then the transfers, and the report in words.

`prepare` reads the files (no link); `connect_and_check` opens the link, reads the vehicle's type,
position and parameters, and judges every check, refusing (Refused, exit code 3) before anything
is sent; `run_upload` does both and, unless asked only to check, sends the mission and reads it
back. Each check is judged once here, whoever shows it.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from aerosurvey.errors import InputError
from aerosurvey.link import mission_protocol as mp
from aerosurvey.link import vehicle_settings as vs
from aerosurvey.link.connection import MavLink, Vehicle, open_link
from aerosurvey.link.upload import (
    VIA_PROTOCOL,
    MissionFacts,
    Progress,
    Refused,
    TransferReport,
    UploadReport,
    accept_names,
    check_px4,
    check_rules,
    check_settings,
    check_vehicle,
    compare_items,
    mission_wire_items,
    settings_to_read,
    upload_mission,
    upload_plan,
)
from aerosurvey.mission.items import Mission
from aerosurvey.report.summary import RuleCount

if TYPE_CHECKING:
    from aerosurvey.airspace.check import AirspaceReport
    from aerosurvey.brief import Item
    from aerosurvey.manifest import Manifest
    from aerosurvey.mission.program import FlightProgram
    from aerosurvey.plan.model import Plan

#: the `--accept` name of the official zones' check at upload
AIRSPACE = "airspace"


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


def plan_manifest(path: Path) -> Manifest | None:
    """The manifest.json beside `path` when it lists this very file (same name and sha256), else None."""
    from aerosurvey import manifest as mf

    doc_path = path.parent / mf.FILE_NAME
    doc = mf.read_manifest(doc_path, "the manifest beside the plan") if doc_path.is_file() else None
    if doc is not None and doc.outputs.get(path.name) != mf.sha256_file(path):
        return None
    return doc


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
    doc = plan_manifest(path)
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


def plan_figures(doc: Manifest) -> vs.PlanFigures:
    """What the vehicle's settings are compared with, from the manifest: the battery's reserve, the
    highest ground under the plan above the launch point (its DEM figures), and the official zones
    near the flights that restrict them (its airspace record; None when the plan was checked against none)."""
    reserve = (doc.raw.get("battery") or {}).get("reserve")
    ground_max = doc.raw["derived"]["terrain"].get("ground_max_m")
    home = doc.home.ground_amsl_m
    airspace = doc.raw.get("airspace")
    zones = None if airspace is None else tuple(
        z["name"] or z["identifier"] for z in airspace["zones"] if z["restriction"] != "NO_RESTRICTION")
    return vs.PlanFigures(reserve, None if ground_max is None or home is None else ground_max - home, zones)


# --- the official zones at upload ---------------------------------------------------------

@dataclass(frozen=True)
class ZonePlan:
    """The plan of an upload made again with official zone files for the window it is flown in:
    `flight` is the uploaded file's stem (its flight program's name), `start`/`end` the window."""

    plan: Plan
    program: FlightProgram
    flight: str
    start: dt.datetime
    end: dt.datetime
    files: tuple[Path, ...]


def zone_plan(path: Path, mission: Mission, zone_files: Sequence[Path], at: dt.datetime,
              spec_path: Path | None = None) -> ZonePlan:
    """The plan `path` was written from, made again from its spec (sha256 checked against the
    manifest's, as `brief` does) with `zone_files` besides the spec's own, for the window from `at`
    to `at` plus the file's flight time (the manifest's): the zones' times are judged in it. Its
    flight must be `mission` item for item: zones the route keeps clear of change the route, and
    then the file is not the flight checked (Refused: plan it again with the zones)."""
    from aerosurvey.airspace.read import read_zone_file
    from aerosurvey.inputs import plan_from_files, planned_spec
    from aerosurvey.mission.builder import mavlink_mission
    from aerosurvey.outputs import mission_programs
    from aerosurvey.spec import load_spec, with_zone_files

    doc = plan_manifest(path)
    if doc is None:
        raise InputError(f"--zones: {path.name} is not listed as it is by a manifest.json beside it, so its plan cannot be "
                         "made again with the zones: upload a file of the folder `aerosurvey plan` wrote", key="--zones")
    sortie = next((s for s in doc.sorties if path.name in s.files), None)
    seconds = doc.estimates.get("total_time_s") if sortie is None else sortie.time_s
    end = at + dt.timedelta(seconds=float(seconds or 0.0))
    spec = with_zone_files(load_spec(planned_spec(path.parent, spec_path, doc.raw["inputs"]["spec"])), zone_files)
    spec = replace(spec, conditions=replace(spec.conditions, start=at, end=end))
    for f in zone_files:  # a file that fails to parse is bad input, not a plan the zones refuse
        read_zone_file(f, "--zones")
    try:
        plan = plan_from_files(spec)
    except InputError as exc:
        raise Refused(f"{path.name}: with the official zones, its plan cannot be made for {_window(at, end)}: {exc}") from None
    program = mission_programs(plan).get(path.stem)
    differs = compare_items(mission_wire_items(mavlink_mission(program)), mission_wire_items(mission)) if program else []
    if program is None or differs:
        what = "has no such flight" if program is None else f"flies another route ({differs[0]})"
        raise Refused(f"{path.name}: its plan made again with the official zones {what}: the zones change the route, so "
                      f"this file is not the flight they were checked on; plan it with --zones and upload that")
    return ZonePlan(plan, program, path.stem, at, end, tuple(zone_files))


def _window(start: dt.datetime, end: dt.datetime) -> str:
    return f"{start.isoformat(timespec='minutes')} to {end.isoformat(timespec='minutes')}"


def zone_report(zp: ZonePlan, vehicle: str, firmware: str, params: dict[str, float]) -> AirspaceReport | None:
    """The official zones against the uploaded flight's every leg, its return flown at the vehicle's
    own RTL altitude (from `params`; where it is when the vehicle does not say) to home or a rally point."""
    from aerosurvey.airspace.check import check_airspace

    return check_airspace(zp.plan, {zp.flight: zp.program}, vs.rtl_altitude(firmware, vehicle, params))


def judge_zones(zp: ZonePlan, report: AirspaceReport | None, facts: MissionFacts, accept: frozenset[str]) -> list[str]:
    """Refuse (Refused) a flight a zone blocks in its window unless `accept` names `airspace`; the report's lines."""
    window = _window(zp.start, zp.end)
    if report is None:
        return ["airspace: no official zone file in the spec nor --zones"]
    lines = [f"airspace: {len(report.airspace.zones)} zone(s) read, {len(report.verdicts)} near {facts.file} flown from "
             f"{window}, its return at the vehicle's RTL altitude"]
    lines += [f"  {v.text()}" for v in report.verdicts if v.verdict == "advise"] + [f"  note: {n}" for n in report.notes]
    refusal = report.refusal()
    if refusal is not None:
        if AIRSPACE not in accept:
            raise Refused(f"{facts.file} flown from {window}: {refusal} (or give --accept {AIRSPACE})")
        lines.insert(1, f"  ACCEPTED by the pilot (--accept {AIRSPACE}): {refusal}")
    return lines


def zone_figures(report: AirspaceReport | None) -> tuple[str, ...] | None:
    """The restricting zones near the flight, as `PlanFigures.zones_near` takes them."""
    if report is None:
        return None
    return tuple(v.zone.label for v in report.verdicts if v.zone.restriction != "NO_RESTRICTION")


# --- the upload -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Prepared:
    """A plan file read, with what the checks compare: its facts, where they came from, the accepted names."""

    path: Path
    mission: Mission
    facts: MissionFacts
    source: str
    accept: frozenset[str]
    rules: str  # the rules' line (a plan that fails a rule the pilot did not accept is refused in `prepare`)
    zones: ZonePlan | None = None


def prepare(path: Path, vehicle: str | None = None, autopilot: str | None = None, accept: Sequence[str] = (),
            zone_files: Sequence[Path] = (), at: dt.datetime | None = None) -> Prepared:
    """Read `path` and its manifest, and refuse what is refused before any link (bad input, failed rules);
    with `zone_files`, make its plan again for the window from `at` (the caller's clock)."""
    mission, waypoints = read_mission(path)
    if autopilot is not None and autopilot != mission.firmware:
        raise InputError(f"--autopilot {autopilot}: {path.name} is a mission for {mission.firmware}; plan it for "
                         f"{autopilot} and upload that", key="--autopilot")
    facts, source = mission_facts(path, mission, waypoints, vehicle)
    accepted = accept_names(facts, accept, (AIRSPACE,) if zone_files else ())
    rules = check_rules(facts, accepted)
    zones = None
    if zone_files:
        if at is None:
            raise ValueError("zone files need the time the flight starts")
        zones = zone_plan(path, mission, zone_files, at)
    return Prepared(path, mission, facts, source, accepted, rules, zones)


@dataclass(frozen=True)
class Checked:
    """The vehicle as connected and every check's line: where it is, its settings, the zones; `params` what it
    answered; `refusals` the checks that refuse (collected only when asked to: else the first is raised)."""

    vehicle: Vehicle
    position: tuple[float, float] | None
    params: dict[str, float]
    where: str
    settings: tuple[str, ...]
    zones: tuple[str, ...]
    refusals: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        return [self.where, *self.settings, *self.zones]


T = TypeVar("T")


def check_connected(link: MavLink, prep: Prepared, policy: mp.Policy, launch_distance: float | None,
                    rally: bool = False, collect: bool = False, params: dict[str, float] | None = None) -> Checked:
    """Every check of the vehicle on `link` (type, position, item count, PX4's storage, zones, settings): Refused
    (one line) for the first that refuses and is not accepted, or with `collect` every refusal in `refusals` (the
    brief lists them all). `params`: the vehicle's parameters when already read (another flight of the same plan)."""
    assert link.vehicle is not None
    facts, m, vehicle = prep.facts, prep.mission, link.vehicle
    refusals: list[str] = []

    def attempt(check: Callable[[], T], otherwise: T) -> T:
        try:
            return check()
        except Refused as exc:
            if not collect:
                raise
            refusals.append(str(exc))
            return otherwise

    position = link.vehicle_position(policy.silence) if launch_distance is not None else None
    where = attempt(lambda: check_vehicle(facts, vehicle, position, launch_distance), "")
    if m.firmware == "px4":
        attempt(lambda: check_px4(m, facts.file, rally), None)
    if params is None:
        params = link.read_params(settings_to_read(facts, vehicle), policy.silence)
    zone_lines: list[str] = []
    if prep.zones is not None:
        zp, report = prep.zones, zone_report(prep.zones, facts.vehicle, m.firmware, params)
        zone_lines = attempt(lambda: judge_zones(zp, report, facts, prep.accept), zone_lines)
        facts = replace(facts, plan=replace(facts.plan, zones_near=zone_figures(report)))
    known, no_lines = params, list[str]()
    settings = attempt(lambda: check_settings(facts, m, vehicle, known, prep.accept), no_lines)
    return Checked(vehicle, position, params, where, tuple(settings), tuple(zone_lines), tuple(refusals))


@dataclass(frozen=True)
class Outcome:
    checked: Checked
    report: UploadReport | None  # None: checked only


def run_upload(url: str, prep: Prepared, policy: mp.Policy, launch_distance: float | None, *, verify: bool = True,
               rally: bool = False, send: bool = True, progress: Progress | None = None) -> Outcome:
    """Connect to `url`, check the vehicle (`check_connected`) and, with `send`, upload the mission and read it
    back (ArduPilot through aerosurvey's protocol, PX4 through MAVSDK on the same connection once the checks'
    link is closed). Without `send` nothing is written to the vehicle, and every refusal is collected in the
    result (`Checked.refusals`) instead of raised."""
    px4 = prep.mission.firmware == "px4"
    if px4:
        from aerosurvey.link.px4 import mavsdk_url

        mavsdk_url(url)  # a connection MAVSDK cannot open is bad input before anything else
    report = None
    with open_link(url, policy.silence) as link:
        checked = check_connected(link, prep, policy, launch_distance, rally, collect=not send)
        if send and not px4:
            report = upload_mission(link, prep.mission, policy, verify=verify, progress=progress, rally=rally)
    if send and px4:
        from aerosurvey.link.px4 import MavsdkTransfers

        with MavsdkTransfers(url, checked.vehicle, policy.timeout, policy.silence, verify) as transfers:
            report = upload_plan(transfers, prep.mission, verify=verify, rally=rally, progress=progress)
    return Outcome(checked, report)


# --- the brief's vehicle checks ---------------------------------------------------------------

def first_flight(plan_dir: Path, doc: Manifest) -> Path:
    """The file of the flight flown first: the first sortie's .plan, else the whole mission's."""
    files = [f for s in doc.sorties for f in s.files if f.endswith(".plan")]
    return plan_dir / (files[0] if files else "mission.plan")


def vehicle_items(plan_dir: Path, doc: Manifest, url: str, policy: mp.Policy,
                  launch_distance: float | None) -> list[Item]:
    """The brief's vehicle checks: `aerosurvey upload`'s checks of the first flight (type, position, item count,
    PX4's storage, settings) against the vehicle at `url`, read only (no mission message is sent); each a line,
    a refusal no-go. A vehicle that cannot be reached is no-go."""
    from aerosurvey.brief import Item
    from aerosurvey.link.connection import LinkError

    path = first_flight(plan_dir, doc)
    try:
        prep = prepare(path)
    except Refused as exc:
        return [Item("vehicle", "no-go", str(exc))]
    try:
        with open_link(url, policy.silence) as link:
            checked = check_connected(link, prep, policy, launch_distance, collect=True)
    except LinkError as exc:
        return [Item("vehicle", "no-go", f"{url}: {exc}")]
    v = checked.vehicle
    out = [Item("vehicle", "go", f"{v.autopilot_name}, MAV_TYPE {v.mav_type}, system {v.system}; checked as "
                                 f"`aerosurvey upload {path.name}` checks it (nothing sent)")]
    out += [Item("vehicle", "no-go", line) for line in checked.refusals]
    out += [Item("vehicle", "go", line) for line in checked.lines() if line]
    return out


# --- the report in words --------------------------------------------------------------------

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


def outcome_lines(prep: Prepared, out: Outcome, verify: bool, rally: bool) -> list[str]:
    """What `aerosurvey upload` prints of an upload that went through (or of its checks only)."""
    f = prep.facts
    lines = [f"{f.file}: {f.vehicle} mission for {f.firmware}, {prep.source}", out.checked.where, prep.rules,
             *out.checked.settings, *out.checked.zones]
    if out.report is not None:
        lines += format_report(out.report, verify, rally)
    if prep.mission.rally and not rally:
        lines.append(f"note: the plan's {len(prep.mission.rally)} rally point(s) were not uploaded; give --rally to "
                     "upload them")
    return lines

