"""`aerosurvey sitl fly`: fly a plan's sorties in ArduPilot SITL and report planned vs flown."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import click

from aerosurvey.errors import InputError
from aerosurvey.fileio import atomic_write_text


def _sorties(outdir: Path) -> tuple[dict, list[tuple[str, Path, list, list, float]]]:
    """(manifest, [(name, mission file, stations (lat, lon), runs, estimated s)]) of a plan folder."""
    mpath = outdir / "manifest.json"
    if not mpath.exists():
        raise InputError(f"{outdir}: manifest.json is missing; give a folder written by `aerosurvey plan`")
    manifest = json.loads(mpath.read_text())
    stations = manifest["stations"]
    index = {s["id"]: i for i, s in enumerate(stations)}

    def part(first: str, last: str) -> tuple[list, list]:
        a, b = index[first], index[last]
        pts = [(s["lat"], s["lon"]) for s in stations[a:b + 1]]
        runs: list[tuple[int, int]] = []  # (first, last) index within this sortie's stations, per run
        for k, s in enumerate(stations[a:b + 1]):
            if runs and stations[a + runs[-1][0]]["line"] == s["line"]:
                runs[-1] = (runs[-1][0], k)
            else:
                runs.append((k, k))
        return pts, runs

    out = []
    if manifest.get("sorties"):
        for s in manifest["sorties"]:
            pts, runs = part(s["first_station"], s["last_station"])
            out.append((s["id"], outdir / s["files"][0], pts, runs, float(s["time_s"])))
    else:
        pts, runs = part(stations[0]["id"], stations[-1]["id"])
        out.append(("mission", outdir / "mission.plan", pts, runs, float(manifest["estimates"]["total_time_s"])))
    return manifest, out


@click.group()
def sitl() -> None:
    """ArduPilot SITL: fly the planned missions in simulation (needs a SITL binary you have)."""


@sitl.command("fly")
@click.argument("outdir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--vehicle", type=click.Choice(["copter", "plane"]), default=None, help="Default: the plan's vehicle.")
@click.option("--speedup", type=click.FloatRange(1, 100), default=10.0, show_default=True, help="SITL speed-up factor.")
@click.option("--sitl-bin", default=None, help="The arducopter/arduplane binary (or its folder); also AEROSURVEY_SITL_BIN.")
@click.option("--defaults", "defaults", multiple=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="ArduPilot default parameter files to start SITL with (e.g. Tools/autotest/default_params/copter.parm); "
                   "default: copter.parm / plane.parm in AEROSURVEY_SITL_DEFAULTS when that folder is set.")
@click.option("--timeout-factor", type=click.FloatRange(1.5, 20), default=3.0, show_default=True,
              help="Give up on a sortie after this many times its estimated time (in simulated time).")
@click.option("-o", "--output", "report_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for the report and logs (default: OUTDIR/sitl).")
def fly(outdir: Path, vehicle: str | None, speedup: float, sitl_bin: str | None, defaults: tuple[Path, ...],
        timeout_factor: float, report_dir: Path | None) -> None:
    """Upload, verify and fly every sortie of OUTDIR in SITL; exit 1 when a sortie does not match its plan."""
    from aerosurvey.link import sitl as harness
    from aerosurvey.link.connection import open_link
    from aerosurvey.link.mission_protocol import Policy
    from aerosurvey.link.upload import upload_mission
    from aerosurvey.mission.formats.qgc_plan import loads_plan

    manifest, sorties = _sorties(outdir)
    vehicle = vehicle or manifest["mission"]["vehicle"]
    binary = harness.find_binary(vehicle, sitl_bin)
    defaults = tuple(defaults) or harness.default_params(vehicle)
    report_dir = report_dir or outdir / "sitl"
    results = []
    for name, path, stations, runs, est in sorties:
        mission = loads_plan(path.read_text(), str(path))
        lat, lon, alt = mission.home
        work = harness.workdir()
        sv = harness.SitlVehicle(binary, vehicle, (lat, lon, alt), speedup, list(defaults), work)
        try:
            sv.start()
            harness.prepare(sv)

            def upload(m) -> str:
                with open_link("tcp:127.0.0.1:5762", 30.0) as link:
                    rep = upload_mission(link, m, Policy())
                return f"{rep.mission.items} items uploaded and verified"

            flight = harness.fly(sv, mission, name, est, len(mission.items), timeout_factor, upload)
        finally:
            sv.stop()
        logs = sorted((work / "logs").glob("*.BIN")) if (work / "logs").exists() else []
        if logs:
            report_dir.mkdir(parents=True, exist_ok=True)
            dest = report_dir / f"{name}.BIN"
            shutil.copyfile(logs[-1], dest)
            flight.log = dest.name
        shutil.rmtree(work, ignore_errors=True)
        row = harness.compare(flight, stations, runs, est)
        if manifest["camera"]["trigger"] == "camera":
            row["triggers_match"] = None  # the camera's own intervalometer is not simulated
        results.append(row)
        click.echo(f"{name}: completed={row['completed']} triggers {row['triggers_flown']}/{row['photos_planned']}, "
                   f"max trigger offset {row['max_trigger_offset_m']} m, max cross-track {row['max_cross_track_m']} m, "
                   f"time {row['flown_time_s']} s flown vs {row['estimated_time_s']} s estimated ({row['time_ratio']})")
    report_dir.mkdir(parents=True, exist_ok=True)
    atomic_write_text(report_dir / "sitl_report.json", json.dumps({"vehicle": vehicle, "binary": str(binary),
                                                                 "speedup": speedup, "sorties": results}, indent=1) + "\n")
    text = "\n".join(f"{r['sortie']}: " + ", ".join(f"{k}={v}" for k, v in r.items() if k != "sortie") for r in results)
    atomic_write_text(report_dir / "sitl_report.txt", text + "\n")
    bad = [r["sortie"] for r in results if not r["completed"] or r["triggers_match"] is False]
    if bad:
        raise harness.SitlError(f"sorties that did not fly as planned: {', '.join(bad)} (see {report_dir / 'sitl_report.txt'})")
