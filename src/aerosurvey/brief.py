"""The pilot's brief for the day (`aerosurvey brief`): what to check before launch, go or no-go.

A brief is made from a plan re-planned for the flying window (the official zones' times and
the sun depend on it) and says, each as go, advise or no-go:
- **airspace**: every official zone the flights meet in that window, with its verdict and
  message (docs/airspace.md); without zone files, that nothing official was checked;
- **batteries**: how many, each one's share of its usable charge, the reserve left on the last;
- **daylight**: the sun's elevation at the first launch and the last landing, sunset (the sun's
  upper limb on the horizon: −0.833°, the standard refraction), and the image-quality threshold;
- **vehicle**: the connected vehicle's settings checks, when the command was given a vehicle.

The flying window starts at `at` and lasts the sorties' flight times plus a battery change
between sorties. The clock, the files and the vehicle are the callers' (commands/brief.py, the
page's web/routes_plan.py): `brief_for` re-plans through the function it is given.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from aerosurvey.plan.sun import sun_elevation_deg

if TYPE_CHECKING:
    from aerosurvey.plan.planner import Plan

#: the verdicts, from best to worst
VERDICTS = ("go", "advise", "no-go")
#: the sun's centre this far below the horizon is sunset: its upper limb on it, with standard refraction
SUNSET_ELEVATION_DEG = -0.833
_SCAN = dt.timedelta(minutes=5)


@dataclass(frozen=True)
class Item:
    topic: str  # plan, airspace, wind, batteries, daylight
    verdict: str  # one of VERDICTS
    text: str


@dataclass(frozen=True)
class Brief:
    start: dt.datetime  # the first launch
    end: dt.datetime  # the last landing
    items: tuple[Item, ...]

    @property
    def verdict(self) -> str:
        return max((i.verdict for i in self.items), key=VERDICTS.index, default="go")

    def lines(self) -> list[str]:
        out = [f"brief for {self.start.isoformat(timespec='minutes')} to {self.end.isoformat(timespec='minutes')}: "
               f"{self.verdict.upper()}"]
        out += [f"  {i.verdict.upper():6} {i.topic}: {i.text}" for i in self.items]
        return out

    def as_dict(self) -> dict[str, Any]:
        return {"start": self.start.isoformat(), "end": self.end.isoformat(), "verdict": self.verdict,
                "items": [{"topic": i.topic, "verdict": i.verdict, "text": i.text} for i in self.items]}


@dataclass(frozen=True)
class Sortie:
    """What the brief needs of one flight of the plan: its id, time and battery use."""

    id: str
    time_s: float
    usable_used_pct: float | None  # of the usable charge (after the reserve); None without a [battery] table
    battery_used_pct: float | None  # of the whole pack


def flying_window(at: dt.datetime, sorties: Sequence[Sortie], battery_change_min: float) -> tuple[dt.datetime, dt.datetime]:
    """From the first launch at `at` to the last landing: the flights one after another, a battery change between."""
    flying = sum(s.time_s for s in sorties)
    changes = max(len(sorties) - 1, 0) * battery_change_min * 60.0
    return at, at + dt.timedelta(seconds=flying + changes)


def sunset_after(lon: float, lat: float, at: dt.datetime) -> dt.datetime | None:
    """The first sunset after `at` within a day (None: the sun stays up, or is down at `at`)."""
    if sun_elevation_deg(lon, lat, at) < SUNSET_ELEVATION_DEG:
        return None
    t = at
    while t < at + dt.timedelta(days=1):
        nxt = t + _SCAN
        if sun_elevation_deg(lon, lat, nxt) < SUNSET_ELEVATION_DEG:
            lo, hi = t, nxt
            while hi - lo > dt.timedelta(seconds=1):
                mid = lo + (hi - lo) / 2
                lo, hi = (mid, hi) if sun_elevation_deg(lon, lat, mid) >= SUNSET_ELEVATION_DEG else (lo, mid)
            return hi
        t = nxt
    return None


def daylight_item(lon: float, lat: float, start: dt.datetime, end: dt.datetime, threshold_deg: float) -> Item:
    first, last = sun_elevation_deg(lon, lat, start), sun_elevation_deg(lon, lat, end)
    at = f"sun {first:.1f}° at the first launch, {last:.1f}° at the last landing"
    if first < SUNSET_ELEVATION_DEG:
        return Item("daylight", "no-go", f"{at}: the first launch is before sunrise")
    sunset = sunset_after(lon, lat, start)
    when = f"sunset {sunset.isoformat(timespec='minutes')}" if sunset is not None else "no sunset within a day"
    if sunset is not None and end > sunset:
        return Item("daylight", "no-go", f"{at}; {when}: the last landing is {(end - sunset).total_seconds() / 60:.0f} min "
                                         "after it")
    low = min(first, last)
    if low < threshold_deg:  # the sun's elevation over a window of hours has its lowest at an end
        return Item("daylight", "advise", f"{at}; {when}; below the {threshold_deg:g}° the spec asks for images "
                                          "(conditions.min_sun_elevation_deg): long shadows hurt image matching")
    return Item("daylight", "go", f"{at}; {when}")


def battery_item(sorties: Sequence[Sortie], reserve: float | None) -> Item:
    if not sorties or sorties[0].usable_used_pct is None:
        return Item("batteries", "advise", f"{max(len(sorties), 1)} flight(s); the spec has no [battery] table, so no "
                                           "battery use is known: check the flight time against the pack")
    worst = max(s.usable_used_pct or 0.0 for s in sorties)
    last = sorties[-1]
    left = 100.0 - (last.battery_used_pct or 0.0)
    text = (f"{len(sorties)} batter{'y' if len(sorties) == 1 else 'ies'}; each flight uses up to {worst:.0f} % of its usable "
            f"charge; the last ({last.id}) lands with {left:.0f} % of the pack"
            + (f" (the reserve kept is {reserve:.0%})" if reserve is not None else ""))
    return Item("batteries", "no-go" if worst > 100.0 else "go", text)


def airspace_items(verdicts: Sequence[tuple[str, str]] | None, notes: Sequence[str] = ()) -> list[Item]:
    """(verdict, text) of every zone the flights meet (airspace.check.ZoneVerdict's), None without zone files."""
    if verdicts is None:
        return [Item("airspace", "advise", "no official zone file was given ([airspace] zones or --zones): the state's "
                                           "airspace was not checked")]
    out = [Item("airspace", {"block": "no-go", "advise": "advise"}.get(v, "go"), text) for v, text in verdicts
           if v in ("block", "advise")]
    out += [Item("airspace", "advise", n) for n in notes]
    if not out:
        out.append(Item("airspace", "go", f"{len(verdicts)} zone(s) near the flights; none applies to them in this window"))
    return out


def make_brief(start: dt.datetime, end: dt.datetime, lon: float, lat: float, threshold_deg: float,
               sorties: Sequence[Sortie], reserve: float | None, airspace: list[Item],
               others: Sequence[Item] = ()) -> Brief:
    return Brief(start, end, (*airspace, *others, battery_item(sorties, reserve),
                              daylight_item(lon, lat, start, end, threshold_deg)))


def manifest_sorties(manifest: Mapping[str, Any]) -> list[Sortie]:
    """The flights of a plan's manifest.json (its sorties, else the one mission)."""
    return ([Sortie(s["id"], float(s["time_s"]), s.get("usable_used_pct"), s.get("battery_used_pct"))
             for s in manifest["sorties"]]
            or [Sortie("mission", float(manifest["estimates"]["total_time_s"]), None, None)])


def plan_records(plan: Plan) -> dict[str, Any]:
    """A plan's flights as its manifest records them (`manifest.sortie_record`): its `sorties` and `estimates`."""
    from aerosurvey import ids
    from aerosurvey.manifest import sortie_record

    return {"sorties": [sortie_record(plan, k, ids.sortie_file_stem(k)) for k in range(1, len(plan.sorties) + 1)],
            "estimates": plan.estimates}


def wind_item(plan: Plan, records: Sequence[Mapping[str, Any]]) -> Item | None:
    """The wind the flights were planned in and the battery it takes (None: still air)."""
    w = plan.wind
    if not w:
        return None
    gusts = f", gusts {w['gust_ms']:g}" if w["gust_ms"] != w["speed_ms"] else ""
    extra = max((float(r.get("wind_used_pct") or 0.0) for r in records), default=0.0)
    return Item("wind", "go", f"{w['speed_ms']:g} m/s from {w['from_deg']:g}° true{gusts}: the flights are timed in it "
                              f"(the wind takes up to {extra:.0f} % of a battery more than still air)")


def brief_for(manifest: Mapping[str, Any], at: dt.datetime, battery_change_min: float,
              replan: Callable[[dt.datetime, dt.datetime], Plan], vehicle: Sequence[Item] = ()) -> Brief:
    """The brief of the plan of `manifest` flown from `at`: `replan(start, end)` makes the plan
    again for that window (from the command's spec files, or the page's spec, in the wind the caller
    gives), whose flights and official zones are then those of the brief (airspace/check.py, as
    `plan` checks them). The window is the manifest's flights' first; when the plan made again
    flies longer (another wind), it is made once more for the longer window. `vehicle`: the connected
    vehicle's checks (link/preflight.py `vehicle_items`), listed after the airspace."""
    from aerosurvey.airspace.check import check_airspace
    from aerosurvey.errors import InputError
    from aerosurvey.outputs import mission_programs

    sorties = manifest_sorties(manifest)
    first, last = flying_window(at, sorties, battery_change_min)
    threshold = float(manifest["conditions"]["threshold_deg"]) if manifest.get("conditions") else 0.0
    extra: list[Item] = []
    try:
        plan = replan(first, last)
        flights = plan_records(plan)
        longer = flying_window(at, manifest_sorties(flights), battery_change_min)[1]
        if longer > last:
            last = longer
            plan = replan(first, last)
            flights = plan_records(plan)
        sorties = manifest_sorties(flights)
        extra = [i for i in (wind_item(plan, flights["sorties"]),) if i is not None]
        report = check_airspace(plan, mission_programs(plan))
        zones = airspace_items(None if report is None else [(v.verdict, v.text()) for v in report.verdicts],
                               () if report is None else report.notes)
        given = (plan.sun or {}).get("threshold_deg")  # the spec's conditions.min_sun_elevation_deg
        if isinstance(given, (int, float)):
            threshold = float(given)
    except InputError as exc:
        zones = [Item("plan", "no-go", f"the plan cannot be made for this window and wind: {exc}")]
    battery = manifest.get("battery") or {}
    home = manifest["home"]
    return make_brief(first, last, float(home["lon"]), float(home["lat"]), threshold, sorties, battery.get("reserve"),
                      zones, [*vehicle, *extra])
