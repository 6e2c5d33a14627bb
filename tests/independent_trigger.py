"""An independent model of ArduPilot's camera triggering, replayed on an exported mission file.

It shares no code with the planner or the mission writers: it reads `mission.waypoints` (QGC
WPL 110) line by line as ArduPilot's mission library takes the items, flies the vehicle along
straight legs between the navigation waypoints at the DO_CHANGE_SPEED speed, and runs the
camera library's rules at its 50 Hz update, as ArduPilot's source has them (AP_Mission.cpp,
AP_Camera.cpp, AP_Camera_Backend.cpp):

- the DO commands between two navigation items run when the vehicle reaches the first of them
  (AP_Mission::advance_current_nav_cmd starts them together with the next navigation item);
- DO_SET_CAM_TRIGG_DIST sets the trigger distance (param1); param3 = 1 takes a picture at once,
  and every picture remembers the place it was taken (AP_Camera_Backend::take_picture);
- at each 50 Hz update: with no positive distance the remembered place is forgotten; with one and
  no remembered place, the current place is remembered (no picture); otherwise a picture is taken
  when the straight distance from the remembered place is the trigger distance or more
  (AP_Camera_Backend::update), measured as ArduPilot's Location::get_distance does, on places
  held as whole 1e-7 degrees (`ardupilot_location`: its flat earth). The vehicle flies its
  speed in these metres too (its navigation turns places into metres the same way);
- DO_SET_CAM_TRIGG_INTERVAL (param1 ms > 0) is a camera clock: a picture at once, then one each
  interval of flight time (at the set speed), until the interval is set to 0.

`replay(path, update_hz=20.0)` is PX4's camera_trigger instead (src/drivers/camera_trigger,
v1.16): the same rules checked every 50 ms (its Run's poll interval) in its local frame (metres
at these lengths as ArduPilot's), where a distance trigger started with param3 = 1 takes its
one picture at once (started without it, PX4 takes one too: our missions always set it).

Each picture carries the index of its trigger-on block (`block`): the photos between one
"camera on" and the next "camera off", which are one planned run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ardupilot_location import LOCATION_SCALING_FACTOR, distance_e7, distance_m, e7
from independent_legs import Item, parse_wpl

NAV_WAYPOINT, NAV_TAKEOFF, NAV_LAND, NAV_RTL = 16, 22, 21, 20
DO_CHANGE_SPEED, DO_SET_CAM_TRIGG_DIST, DO_SET_CAM_TRIGG_INTERVAL = 178, 206, 214
UPDATE_HZ = 50.0
#: ArduPilot's metres per degree of latitude
_M_PER_DEG = LOCATION_SCALING_FACTOR * 1e7


@dataclass
class Photo:
    lat: float
    lon: float
    block: int  # trigger-on block: 0 for the first "camera on" of the mission, 1 for the next …


@dataclass
class _Camera:
    dist: float = 0.0
    interval_m: float = 0.0  # camera clock as metres of flight at the set speed
    last: tuple[int, int] | None = None  # the last picture's place, in 1e-7 degrees
    flown: float = 0.0  # metres flown since the camera clock's last picture
    block: int = -1
    photos: list[Photo] = field(default_factory=list)

    def picture(self, lat: float, lon: float) -> None:
        self.last = (e7(lat), e7(lon))
        self.photos.append(Photo(self.last[0] / 1e7, self.last[1] / 1e7, self.block))
        self.flown = 0.0

    def update(self, lat: float, lon: float) -> None:
        """AP_Camera_Backend::update's distance trigger at one 50 Hz tick."""
        if self.interval_m > 0:
            if self.flown >= self.interval_m:
                self.picture(lat, lon)
            return
        if self.dist <= 0:
            self.last = None
            return
        here = (e7(lat), e7(lon))
        if self.last is None:
            self.last = here
            return
        if self.last == here:
            return
        if distance_e7(*self.last, *here) >= self.dist:
            self.picture(lat, lon)


def replay(path: Path, update_hz: float = UPDATE_HZ) -> list[Photo]:
    """The pictures ArduPilot takes flying the mission file, in order (PX4 with `update_hz` 20)."""
    home, items = parse_wpl(path.read_text(), str(path))
    cam = _Camera()
    here = (home.lat, home.lon)
    speed = 0.0
    tick = 0.0  # metres to the next 50 Hz update
    pending: list[Item] = []  # DO commands waiting for the vehicle to reach the previous navigation item

    def run_do(it: Item) -> None:
        nonlocal speed
        if it.command == DO_CHANGE_SPEED and it.params[1] > 0:
            speed = it.params[1]
        elif it.command == DO_SET_CAM_TRIGG_DIST:
            cam.dist = it.params[0]
            if cam.dist > 0:
                cam.block += 1
            if it.params[2] == 1:
                cam.picture(*here)
        elif it.command == DO_SET_CAM_TRIGG_INTERVAL:
            cam.interval_m = speed * it.params[0] / 1000.0 if it.params[0] > 0 else 0.0
            if cam.interval_m > 0:
                cam.block += 1
                cam.picture(*here)

    for it in items:
        if it.command not in (NAV_WAYPOINT, NAV_TAKEOFF, NAV_LAND, NAV_RTL):
            pending.append(it)
            continue
        for do in pending:  # reached the previous navigation item: its DO commands run
            run_do(do)
        pending = []
        if it.command == NAV_RTL:
            target = (home.lat, home.lon)
        elif it.lat == 0 and it.lon == 0 or it.command == NAV_TAKEOFF:
            target = here
        else:
            target = (it.lat, it.lon)
        length = distance_m(here[0], here[1], target[0], target[1])
        step = speed / update_hz if speed > 0 else 0.1
        s = 0.0
        while length > 0 and s + tick <= length:
            s += tick
            cam.flown += tick
            f = s / length
            cam.update(here[0] + (target[0] - here[0]) * f, here[1] + (target[1] - here[1]) * f)
            tick = step
        if length > 0:
            tick -= length - s
            cam.flown += length - s
        here = target
    return cam.photos
