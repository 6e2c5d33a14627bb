"""Render and write every output of `aerosurvey plan`, all or nothing."""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aerosurvey import ids
from aerosurvey import manifest as mf
from aerosurvey.errors import CheckFailed
from aerosurvey.fileio import atomic_write_bytes, staged_directory
from aerosurvey.mission.builder import mavlink_mission
from aerosurvey.mission.formats import DJI_TEMPLATES, QGC_LAYOUTS
from aerosurvey.mission.formats.kml import layers_to_kml
from aerosurvey.mission.formats.qgc_plan import dumps_plan
from aerosurvey.mission.formats.qgc_survey import QGC_FRAMES, SurveyShapes, survey_blocks, survey_items, survey_shapes
from aerosurvey.mission.formats.wpl import dumps_wpl
from aerosurvey.mission.gate import check_legs, program_legs
from aerosurvey.mission.items import Mission
from aerosurvey.mission.program import FlightProgram, flight_program
from aerosurvey.mission.targets import dji_aircraft, mavlink_item_limit
from aerosurvey.plan.coverage import planner_rules
from aerosurvey.plan.landing import PLANE_RTL_LOITER_M
from aerosurvey.plan.planner import Plan
from aerosurvey.spec import MissionSpec

if TYPE_CHECKING:
    from aerosurvey.airspace.check import AirspaceReport
    from aerosurvey.mission.clearance import ClearanceReport
    from aerosurvey.rules.control_points import ControlPoint
    from aerosurvey.rules.engine import Evidence, RuleResult
from aerosurvey.report.features import footprint_lonlat, plan_geojson
from aerosurvey.report.gpkg import footprints_layer, gpkg_bytes, plan_layers
from aerosurvey.report.preview import render_svg
from aerosurvey.report.summary import Summary, plan_summary

log = logging.getLogger(__name__)


class _Decoded(Mapping[str, str]):
    """File name → text, read from the file's UTF-8 bytes when asked for."""

    def __init__(self, data: Mapping[str, bytes]) -> None:
        self._data = data

    def __getitem__(self, name: str) -> str:
        return self._data[name].decode("utf-8")

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)


@dataclass(frozen=True)
class Rendered:
    """Every output of a plan as the bytes written. The text files are held as their UTF-8 bytes
    (`text_bytes`), each encoded once, as soon as it is made, for its hash in the manifest and its
    file, its text then let go: a 100 km² plan's texts are 64 MB, and each held once (`files` reads
    them as text)."""

    text_bytes: dict[str, bytes]  # file name → UTF-8 bytes of the text outputs
    rules: list[dict[str, Any]]  # every rule result, the planner's own included (manifest "rules")
    warnings: list[str]
    summary: Summary
    evidence: Any = None  # the rules' Evidence (footprints, proposed control points) when profiles were evaluated
    binary: dict[str, bytes] = field(default_factory=dict)  # file name → bytes of the binary outputs (plan.gpkg when asked)

    @property
    def files(self) -> Mapping[str, str]:
        """File name → text of the text outputs."""
        return _Decoded(self.text_bytes)


def item_limit_warnings(plan: Plan, mission: Mission) -> list[str]:
    """A mission longer than the autopilot holds is flagged with what to do about it."""

    limit = mavlink_item_limit(plan.vehicle.firmware, plan.battery)
    n = len(mission.items) + 1
    if n > limit:
        msg = (f"the whole mission has {n} items, more than the {limit} a {plan.vehicle.firmware} autopilot holds "
               f"by default (battery.max_mission_items)")
        if plan.sorties:
            return [msg + "; fly the sortie files, each within the limit"]
        return [msg + "; add a [battery] table so the plan is split into sorties that fit, "
                "or raise battery.max_mission_items if your board holds more"]
    return []


def final_gate(plan: Plan, programs: dict[str, FlightProgram]) -> None:
    """Every leg of every flight outside the zones and their margins, or nothing is written."""
    bad = []
    for stem, p in programs.items():
        legs = program_legs(p, stem, plan.site.planar, PLANE_RTL_LOITER_M * plan.site.grid_scale, plan.site.grid_scale)
        bad += check_legs(legs, plan.site.zones, plan.site.margin_m, plan.site.grid_scale, plan.site.planar)
    if bad:
        more = f" (and {len(bad) - 3} more)" if len(bad) > 3 else ""
        raise CheckFailed("the plan is not written: " + "; ".join(v.message() for v in bad[:3]) + more)


def airspace_gate(plan: Plan, programs: dict[str, FlightProgram]) -> AirspaceReport | None:
    """Every leg of every flight against the official zones in four dimensions (airspace/check.py): a zone that blocks
    a leg stops the plan with the zone, the leg and the figures; else the report of every zone near the flights."""
    if plan.airspace is None:
        return None
    from aerosurvey.airspace.check import check_airspace

    report = check_airspace(plan, programs)
    refusal = report.refusal() if report is not None else None
    if refusal is not None:
        raise CheckFailed("the plan is not written: " + refusal)
    return report


def terrain_gate(plan: Plan, programs: dict[str, FlightProgram]) -> ClearanceReport | None:
    """Every leg of every flight at least terrain.min_clearance_m above the DEM (mission/clearance.py), or nothing is
    written; None without a DEM."""
    site = plan.site
    if site.dem is None:
        return None
    from aerosurvey.mission.clearance import terrain_clearance

    report = terrain_clearance(programs, site.dem, site.planar, site.grid_scale, site.min_clearance_m,
                               PLANE_RTL_LOITER_M * site.grid_scale, plan.sensor.turn_radius_m * site.grid_scale)
    refusal = report.refusal()
    if refusal is not None:
        raise CheckFailed("the plan is not written: " + refusal)
    return report


def planner_airspace_rule(report: AirspaceReport | None) -> list[dict[str, Any]]:
    """The planner's airspace rule as a manifest rule record, when the plan was checked against official zones."""
    return [] if report is None else [report.rule_record()]


def _rules(spec: MissionSpec, manifest: dict[str, Any], stations: mf.StationTable,
           features: dict[str, Any]) -> tuple[list[RuleResult], list[ControlPoint], Evidence | None]:
    """Evaluate the spec's rule profiles on the plan as later readers will see it (the
    manifest with its station rows, made here only when there are profiles to read them)."""
    if not spec.profiles:  # the rules' modules are not loaded for a plan without profiles
        return [], [], None
    from aerosurvey.rules.engine import Evidence, evaluate, layout_settings
    from aerosurvey.rules.planview import PlanView
    from aerosurvey.rules.profile import apply_overrides, select_profiles

    view = PlanView.from_documents({**manifest, "stations": stations.rows()}, features, "the plan",
                                   check=False)  # just made by the writer
    profiles = apply_overrides(select_profiles(list(spec.profiles)), spec.rule_overrides)
    ev = Evidence(view, layout_settings(view, profiles))
    return evaluate(profiles, ev), ev.points, ev


def plan_text(plan: Plan, shapes: SurveyShapes | None, m: Mission) -> str:
    """A mission's .plan: with `shapes` (`survey_shapes` of the stations it flies, for `--qgc
    survey`) each photo pass in a QGroundControl complex item, without every item plain."""
    return dumps_plan(m, survey_items(plan, shapes, m) if shapes is not None else ())


def render_outputs(plan: Plan, spec: MissionSpec, gpkg: bool = False, qgc: str = QGC_LAYOUTS[0],
                   dji: str = DJI_TEMPLATES[0]) -> Rendered:
    """Every output of `plan`, planned from `spec` (the manifest last: it lists the others' hashes);
    with `gpkg`, plan.gpkg too (report/gpkg.py; it costs more than the rest together, so it
    is made when asked); `qgc` is how the .plan files hold the passes (`plan_text`), `dji`
    which template the DJI .kmz files hold (`dji_kmz_files`)."""
    # one flight program per file stem (the whole mission and each sortie), checked once, then emitted
    programs = mission_programs(plan)
    final_gate(plan, programs)
    airspace = airspace_gate(plan, programs)
    clearance = terrain_gate(plan, programs)
    mission = mavlink_mission(programs["mission"])
    # the station table's columns are written into the manifest and plan.geojson, and the
    # rules make its rows; the footprints' corners go into plan.geojson and plan.gpkg
    stations_table = mf.station_table(plan)
    corners = footprint_lonlat(plan)
    fc, _, geojson = plan_geojson(plan, stations_table, corners)
    text_bytes = {"plan.geojson": geojson.encode("utf-8")}  # each text encoded once, as soon as it is made (`Rendered`)
    del geojson  # held as its bytes only
    missions = {stem: mission if stem == "mission" else mavlink_mission(p) for stem, p in programs.items()}
    text_bytes |= {name: text.encode("utf-8") for name, text in _mission_files(plan, missions, qgc).items()}
    warnings = list(plan.warnings) + item_limit_warnings(plan, mission)
    manifest = mf.build_manifest(plan, spec, len(mission.items), {}, with_stations=False)
    if airspace is not None:
        manifest["airspace"] = mf.airspace_record(airspace, spec)
        warnings += [f"airspace: {v.text()}" for v in airspace.of("advise")] + [f"airspace: {n}" for n in airspace.notes]
    if clearance is not None:
        manifest["clearance"] = clearance.manifest_record()
    results, points, evidence = _rules(spec, manifest, stations_table, fc)
    for r in results:
        if r.status in ("fail", "warning"):
            warnings.append(f"rule {r.rule} ({r.profile}) fails: measured {r.outcome.measured}, required {r.outcome.required}")
    manifest["rules"] = [r.as_dict() for r in results] + planner_rules(plan) + planner_airspace_rule(airspace) \
        + ([clearance.rule_record()] if clearance is not None else [])
    summary = plan_summary(manifest, manifest["rules"])
    text_bytes["preview.svg"] = render_svg(plan, summary, points).encode("utf-8")
    binary, dji_warnings = dji_kmz_files(plan, programs, dji)
    warnings += dji_warnings
    # plan.kml and plan.gpkg: the same layers, the rules' proposed control points among them;
    # the footprints only in the GeoPackage (thousands of rectangles clutter Google Earth)
    layers = plan_layers(plan, points)
    text_bytes["plan.kml"] = layers_to_kml(layers, plan.name).encode("utf-8")
    if gpkg:
        binary["plan.gpkg"] = gpkg_bytes([*layers, footprints_layer(plan, corners)])
    written = text_bytes | binary
    manifest["outputs"] = {name: _sha256(written[name]) for name in sorted(written)}
    if plan.coverage.uncovered_m2 > 0:
        warnings.append(f"rule uncovered-ground (plan) fails: measured {plan.coverage.uncovered_m2:.0f} m², required 0 m²")
    manifest["warnings"] = warnings
    text_bytes["manifest.json"] = mf.dumps(manifest, stations_table).encode("utf-8")
    return Rendered(text_bytes, manifest["rules"], warnings, summary, evidence, binary)


def dji_kmz_files(plan: Plan, programs: dict[str, FlightProgram], dji: str = DJI_TEMPLATES[0]) -> tuple[dict[str, bytes], list[str]]:
    """A DJI WPML .kmz next to each flight's .plan and .waypoints when the camera is one a DJI
    aircraft flies waylines with (mission/formats/wpml.py), and a warning for each flight that
    cannot be one (with why). `dji` "mapping": template.kml holds a mapping template where one
    expresses the flight (mission/formats/dji_template.py), "waypoint": always the waypoint template."""
    aircraft = dji_aircraft(programs["mission"].camera_id)
    if aircraft is None:
        return {}, []
    # the writer (and lxml) loads for a DJI camera only: not at every plan's start
    from aerosurvey.mission.formats import wpml
    from aerosurvey.mission.formats.dji_template import template_choice

    files: dict[str, bytes] = {}
    warnings: list[str] = []
    for stem, p in programs.items():
        why = wpml.refusal(p)
        if why is None:
            # the whole mission, or its one sortie, flies every station
            template = template_choice(plan, p, stem == "mission" or len(plan.sorties) == 1, dji)
            if isinstance(template, str):
                log.info("%s.kmz: waypoint template (%s)", stem, template)
            files[f"{stem}.kmz"] = wpml.kmz_bytes(p, aircraft, template)
        else:
            warnings.append(f"{stem}.kmz (DJI waylines for the {aircraft.name}) is not written: {why}")
    return files, warnings


def mission_programs(plan: Plan) -> dict[str, FlightProgram]:
    """The flight program of the whole mission ("mission") and of each sortie, by file stem."""
    return {"mission": flight_program(plan)} | _sortie_programs(plan, ids.sortie_file_stem)


def _sortie_programs(plan: Plan, stem: Callable[[int], str]) -> dict[str, FlightProgram]:
    """Each sortie's flight program from its launch site, by file stem."""
    return {stem(k): flight_program(plan, k - 1, name=f"{plan.name}-{stem(k)}") for k in range(1, len(plan.sorties) + 1)}


def _mission_files(plan: Plan, missions: dict[str, Mission], qgc: str) -> dict[str, str]:
    """Each flight's .plan and .waypoints: the whole mission's ("mission", all stations) and
    the sorties' (the other stems, in the order of plan.sorties, each flying its stations)."""
    if qgc not in QGC_LAYOUTS:
        raise ValueError(f"qgc = {qgc!r}: one of {', '.join(QGC_LAYOUTS)}")
    sorties = iter(plan.sorties)
    frame = QGC_FRAMES.get(qgc)
    out = {}
    for stem, m in missions.items():
        stations = None
        if stem != "mission":
            sortie = next(sorties).sortie
            stations = (sortie.first, sortie.last)
        passes = [p for p, _, _ in survey_blocks(m)]
        shapes = survey_shapes(plan, passes, frame, stations) if frame is not None else None
        for why in shapes.plain if shapes is not None else ():
            log.info("%s.plan: plain items for %s", stem, why)
        out[f"{stem}.plan"] = plan_text(plan, shapes, m)
        out[f"{stem}.waypoints"] = dumps_wpl(m)
    return out


def render_resume(plan: Plan, stations_done: int, counted: tuple[str, ...], plan_folder: str,
                  qgc: str = QGC_LAYOUTS[0]) -> dict[str, str]:
    """File name → text of a resumed flight (`planner.resume_mission`): each sortie's .plan and
    .waypoints (resume-01 …), every leg through the final gate, and resume.json saying which
    station the flight resumes from, what was counted as done and why, and what each sortie flies."""
    from aerosurvey import resumefile  # `resume` only: not loaded by `plan`

    programs = _sortie_programs(plan, ids.resume_file_stem)
    final_gate(plan, programs)
    airspace_gate(plan, programs)
    terrain_gate(plan, programs)
    files = _mission_files(plan, {stem: mavlink_mission(p) for stem, p in programs.items()}, qgc)
    sorties = [mf.sortie_record(plan, k, ids.resume_file_stem(k)) for k in range(1, len(plan.sorties) + 1)]
    first = plan.stations.ids[plan.sorties[0].sortie.first]
    files[resumefile.FILE] = resumefile.dumps(plan.name, plan_folder, first, stations_done, counted, sorties)
    return files


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def write_outputs(plan: Plan, spec: MissionSpec, outdir: Path, gpkg: bool = False, qgc: str = QGC_LAYOUTS[0],
                  dji: str = DJI_TEMPLATES[0]) -> Rendered:
    """Render everything first, then move it into `outdir`; an error leaves `outdir` untouched."""
    rendered = render_outputs(plan, spec, gpkg, qgc, dji)
    with staged_directory(outdir) as stage:
        for name, data in (rendered.text_bytes | rendered.binary).items():
            atomic_write_bytes(stage / name, data)
    return rendered
