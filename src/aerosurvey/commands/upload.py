"""`aerosurvey upload`: send a plan to a vehicle over MAVLink, read it back and compare.

Exit codes: 0 uploaded and verified (or uploaded with --no-verify), 1 the link failed or the
vehicle stores something else, 2 bad input (unreadable plan, bad option, wrong firmware).
Nothing is reported as uploaded unless the vehicle acknowledged every item.
"""

from __future__ import annotations

from pathlib import Path

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
    return m


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
    something else (the differing item, field and values are named), 2 for bad input.
    """
    mission = read_mission(plan_file)
    policy = mp.Policy(timeout=timeout, retries=retries)
    with open_link(url, timeout * (retries + 1)) as link:
        try:
            report = upload_mission(link, mission, policy, verify=not no_verify)
        except VerificationFailed as exc:
            for mm in exc.mismatches[:20]:
                click.echo(f"  differs: {mm}", err=True)
            if len(exc.mismatches) > 20:
                click.echo(f"  ... {len(exc.mismatches) - 20} more", err=True)
            raise
    for line in format_report(report, not no_verify):
        click.echo(line)
