"""`aerosurvey sitl fly`: fly a plan's sorties in ArduPilot or PX4 SITL and report planned vs flown."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from aerosurvey import console


@click.group()
def sitl() -> None:
    """ArduPilot or PX4 SITL: fly the planned missions in simulation (needs a SITL binary you have)."""


@sitl.command("fly")
@click.argument("outdir", type=click.Path(file_okay=False, exists=True, path_type=Path))
@click.option("--vehicle", type=click.Choice(["copter", "plane"]), default=None, help="Default: the plan's vehicle.")
@click.option("--speedup", type=click.FloatRange(1, 100), default=10.0, show_default=True, help="SITL speed-up factor.")
@click.option("--firmware", type=click.Choice(["ardupilot", "px4"]), default=None,
              help="The autopilot to fly in (default: the plan's firmware). PX4 flies its SIH quadrotor.")
@click.option("--sitl-bin", default=None, help="The arducopter/arduplane binary (or its folder); also AEROSURVEY_SITL_BIN.")
@click.option("--px4-bin", default=None,
              help="PX4's SITL binary, build/px4_sitl_default/bin/px4 (or its folder; its etc/ beside bin/); "
                   "also AEROSURVEY_PX4_BIN.")
@click.option("--defaults", "defaults", multiple=True, type=click.Path(dir_okay=False, exists=True, path_type=Path),
              help="ArduPilot default parameter files to start SITL with (e.g. Tools/autotest/default_params/copter.parm); "
                   "default: copter.parm / plane.parm in AEROSURVEY_SITL_DEFAULTS when that folder is set.")
@click.option("--timeout-factor", type=click.FloatRange(1.5, 20), default=3.0, show_default=True,
              help="Give up on a sortie after this many times its estimated time (in simulated time).")
@click.option("--boot-timeout", type=click.FloatRange(0.5, 600), default=60.0, show_default=True,
              help="Seconds SITL may take to start and send its first heartbeat.")
@click.option("-o", "--output", "report_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for the report and logs (default: OUTDIR/sitl, or RESUME/sitl with --resume).")
@click.option("--resume", "resume_dir", type=click.Path(file_okay=False, exists=True, path_type=Path), default=None,
              help="Fly the sorties `aerosurvey resume` wrote into this folder instead of OUTDIR's own.")
@click.option("--rtl-after", "rtl_after", type=click.IntRange(min=1), default=None, metavar="N",
              help="A flight cut short: fly the first sortie only and switch it to RTL after its Nth photo (ArduPilot "
                   "keeps triggering by distance in RTL); its log is the input of `aerosurvey resume`.")
def fly(outdir: Path, vehicle: str | None, speedup: float, firmware: str | None, sitl_bin: str | None, px4_bin: str | None,
        defaults: tuple[Path, ...], timeout_factor: float, boot_timeout: float, report_dir: Path | None,
        resume_dir: Path | None, rtl_after: int | None) -> None:
    """Upload, verify and fly every sortie of OUTDIR in SITL; exit 1 when a sortie does not match its plan.

    SITL runs in a temporary folder, removed afterwards; paths given here are taken from the
    current folder. When SITL fails, the error quotes the last lines it printed. A sortie cut
    short on purpose (--rtl-after) is reported, not judged; exit 1 when it was not cut (it
    took fewer photos).
    """
    # the SITL harness and pymavlink load only when the command runs
    from aerosurvey.flight.sitl_run import SitlSettings, fly_sorties
    from aerosurvey.link import sitl as harness
    from aerosurvey.manifest import read_manifest

    doc = read_manifest(outdir, "OUTDIR")
    vehicle = vehicle or doc.mission.vehicle
    firmware = firmware or doc.mission.firmware
    # the wind the plan was made for, simulated steady (SIM_WIND_SPD, SIM_WIND_DIR; no turbulence)
    wind = None if doc.wind is None else (float(doc.wind["speed_ms"]), float(doc.wind["from_deg"]))
    if firmware == "px4":
        from aerosurvey.link.px4_sitl import find_px4

        _px4_fits(doc.mission.firmware, vehicle, doc.camera.trigger, defaults, rtl_after, wind)
        settings = SitlSettings(vehicle, find_px4(px4_bin), (), speedup, timeout_factor, boot_timeout, None, "px4")
    else:
        settings = SitlSettings(vehicle, harness.find_binary(vehicle, sitl_bin),
                                tuple(defaults) or harness.default_params(vehicle), speedup, timeout_factor, boot_timeout,
                                rtl_after, wind=wind)
    report_dir = report_dir or (resume_dir or outdir) / "sitl"
    results = fly_sorties(doc, outdir, settings, report_dir, _echo_row, resume_dir)
    if rtl_after is not None:
        bad = [r["sortie"] for r in results if r["rtl_after_photos"] is None]
        if bad:
            raise harness.SitlError(f"sortie {bad[0]} was not cut: it took {results[0]['triggers_flown']} photos, "
                                    f"--rtl-after {rtl_after} asks for more (see {report_dir / 'sitl_report.txt'})")
        return
    bad = [r["sortie"] for r in results if not r["completed"] or r["triggers_match"] is False or r.get("aim_ok") is False]
    if bad:
        raise harness.SitlError(f"sorties that did not fly as planned: {', '.join(bad)} (see {report_dir / 'sitl_report.txt'})")


def _px4_fits(planned: str, vehicle: str, trigger: str, defaults: tuple[Path, ...], rtl_after: int | None,
              wind: tuple[float, float] | None = None) -> None:
    """What PX4 SITL does not fly is bad input (InputError), before anything starts."""
    from aerosurvey.errors import InputError

    if planned != "px4":
        raise InputError(f"--firmware px4: OUTDIR is a plan for {planned}; plan it with vehicle.firmware = \"px4\"",
                         key="--firmware")
    if vehicle != "copter":
        raise InputError(f"--firmware px4 flies PX4's SIH quadrotor: a {vehicle} plan is not flown in PX4 SITL here",
                         key="--vehicle")
    if trigger not in ("distance", "camera"):
        # PX4's camera_trigger driver starts an interval on DO_TRIGGER_CONTROL only, and leaves
        # IMAGE_START_CAPTURE to a MAVLink camera: SITL logs no camera_capture for these missions
        raise InputError(f"--firmware px4: camera.trigger = {trigger!r} is not flown in PX4 SITL (its camera_trigger "
                         "driver logs no photo for that mission); allowed: distance, camera", key="--firmware")
    if defaults:
        raise InputError("--defaults are ArduPilot parameter files; PX4 SITL takes sitl/aerosurvey-px4.params",
                         key="--defaults")
    if wind is not None:
        raise InputError(f"--firmware px4: the plan's wind ({wind[0]:g} m/s from {wind[1]:g}°) is simulated in ArduPilot "
                         "SITL only here; plan it without conditions.wind to fly it in PX4's SIH", key="--firmware")
    if rtl_after is not None:
        raise InputError("--rtl-after cuts an ArduPilot flight (its camera feedback arrives as it flies); not with "
                         "--firmware px4", key="--rtl-after")


def _echo_row(row: dict[str, Any]) -> None:
    console.echo(f"{row['sortie']}: completed={row['completed']} triggers {row['triggers_flown']}/{row['photos_planned']}, "
               f"max trigger offset {row['max_trigger_offset_m']} m, max cross-track {row['max_cross_track_m']} m, "
               f"time {row['flown_time_s']} s flown vs {row['estimated_time_s']} s estimated ({row['time_ratio']})")
