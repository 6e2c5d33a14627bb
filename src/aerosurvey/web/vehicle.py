"""The page's vehicle (`aerosurvey serve --connect URL`): a plan's mission file checked against it, or
uploaded to it and read back, as `aerosurvey upload` does (link/preflight.py), run as a job; and the
vehicle's checks in the page's brief, as `aerosurvey brief --connect` makes them.

The file and its manifest.json are written into a folder of their own under the server's scratch space
(the checks read the manifest beside the file, as they do for the command). One vehicle job at a time:
a second is refused while one talks to the vehicle. A check sends nothing to the vehicle but requests for
its position and parameters; only an upload (the pilot's click) sends a mission.
"""

from __future__ import annotations

import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from aerosurvey.errors import InputError
from aerosurvey.web.jobs import Progress
from aerosurvey.web.service import PlanBundle

if TYPE_CHECKING:
    from aerosurvey.brief import Item

#: the mission files a vehicle takes from the page
UPLOADABLE = (".plan", ".waypoints")


@dataclass
class VehicleLink:
    """The vehicle the server was started with and the lock that lets one job at a time talk to it."""

    url: str
    busy: threading.Lock = field(default_factory=threading.Lock)


def vehicle_job(vehicle: VehicleLink, bundle: PlanBundle, name: str, scratch: Path, send: bool,
                progress: Progress) -> dict[str, Any]:
    """Check `name` of `bundle` against the vehicle (all refusals listed), or with `send` upload it, read it back
    and compare (the first refusal stops it, as the command's does). The result says what the page shows."""
    from aerosurvey.link import mission_protocol as mp
    from aerosurvey.link.preflight import format_report, outcome_lines, prepare, run_upload
    from aerosurvey.link.upload import LAUNCH_DISTANCE_M, held_mission
    from aerosurvey.mission.formats.wpl import dumps_wpl

    if not name.endswith(UPLOADABLE) or name not in bundle.files:
        raise InputError(f"{name!r} is not a mission file of the plan: one of "
                         f"{', '.join(n for n in bundle.names() if n.endswith(UPLOADABLE))}", key="vehicle")
    progress("checks", 0.0)
    with talking_to(vehicle), plan_folder(bundle, name, scratch) as folder:
        prep = prepare(folder / name)

        def transfer(what: str, done: int, total: int) -> None:
            progress(what, done / total if total else 1.0)

        out = run_upload(vehicle.url, prep, mp.Policy(), LAUNCH_DISTANCE_M, send=send, progress=transfer)
    c = out.checked
    result: dict[str, Any] = {
        "file": name, "sent": send,
        "vehicle": {"autopilot": c.vehicle.autopilot_name, "mav_type": c.vehicle.mav_type, "system": c.vehicle.system},
        "position": list(c.position) if c.position is not None else None,
        "launch": list(prep.facts.launch),
        "checks": [*([prep.rules] if prep.rules else []), *(line for line in c.lines() if line)],
        "refusals": list(c.refusals),
        "lines": outcome_lines(prep, out, True, False),
        "verified": False,
    }
    if out.report is not None:
        result["report"] = format_report(out.report, True)
        result["verified"] = all(t.verified for t in out.report.transfers)
        held = out.report.mission.held
        if held is not None:
            m = held_mission(prep.mission, held)
            result["held_home"] = [m.home[0], m.home[1]]
            result["held_waypoints"] = dumps_wpl(m)
    return result


def brief_items(vehicle: VehicleLink, bundle: PlanBundle, scratch: Path) -> list[Item]:
    """The vehicle's checks in the brief of `bundle` (link/preflight.py `vehicle_items`: the first flight's file
    checked as `aerosurvey brief --connect` checks it, read only, within 200 m of its launch point)."""
    from aerosurvey.link import mission_protocol as mp
    from aerosurvey.link.preflight import first_flight, vehicle_items
    from aerosurvey.link.upload import LAUNCH_DISTANCE_M

    assert bundle.manifest is not None, "a plan's brief"
    name = first_flight(Path(), bundle.manifest).as_posix()
    with talking_to(vehicle), plan_folder(bundle, name, scratch) as folder:
        return vehicle_items(folder, bundle.manifest, vehicle.url, mp.Policy(), LAUNCH_DISTANCE_M)


@contextmanager
def talking_to(vehicle: VehicleLink) -> Iterator[None]:
    """The vehicle for one job; InputError while another job talks to it."""
    if not vehicle.busy.acquire(blocking=False):
        raise InputError("the vehicle is busy with another check or upload: wait for it to end", key="vehicle")
    try:
        yield
    finally:
        vehicle.busy.release()


@contextmanager
def plan_folder(bundle: PlanBundle, name: str, scratch: Path) -> Iterator[Path]:
    """A folder of its own under `scratch` holding the plan's file `name` and its manifest.json (the checks read
    the manifest beside the file, as they do for the commands), removed at the end."""
    with tempfile.TemporaryDirectory(dir=scratch, prefix="vehicle-") as tmp:
        folder = Path(tmp)
        for n in (name, "manifest.json"):
            if n in bundle.files:
                (folder / n).parent.mkdir(parents=True, exist_ok=True)
                (folder / n).write_text(bundle.files[n], encoding="utf-8")
        yield folder
