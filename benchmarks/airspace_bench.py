"""1,000 official zones against a 20-sortie plan: how long the 4-D check of every leg takes.

    python benchmarks/airspace_bench.py              # 1000 zones, seed 1
    python benchmarks/airspace_bench.py --zones 5000 --seed 3

The plan is the Obrataň example (72 ha, copter) with a battery small enough for about 20
sorties. The zones, written as one ED-269 file: circles and polygons of 50 m to 2 km scattered
over 30 x 30 km round the area (a few dozen over it), each CONDITIONAL, REQ_AUTHORISATION or
NO_RESTRICTION, with random AGL bands (some over the flight's heights, some below or above
them) and half with a weekly schedule; the operator holds every authorisation, so no zone
blocks and the route is the example's. Printed: the file's reading time, the planning time
with the zones, and the check's time (`check_airspace`: every leg of the mission and of each
sortie against every zone, the zones indexed with STRtrees), the best of three; the legs, the
zones near the flights and the verdicts. No timed assert: the figure goes in the issue note.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def zone_file(path: Path, n: int, seed: int, centre: tuple[float, float]) -> None:
    rng = np.random.default_rng(seed)
    lon0, lat0 = centre
    features = []
    for i in range(n):
        near = i < n // 25  # a few dozen over the area
        spread = 0.004 if near else 0.2
        lon, lat = lon0 + rng.uniform(-spread, spread), lat0 + rng.uniform(-spread * 0.66, spread * 0.66)
        size_m = rng.uniform(50, 2000)
        lower = float(rng.choice([0, 20, 50, 150]))
        upper = float(rng.choice([60, 120, 300, 99999]))
        if upper < lower:
            lower, upper = upper, lower
        if rng.random() < 0.5:
            hp = {"type": "Circle", "center": [lon, lat], "radius": round(size_m / 2, 1)}
        else:
            d_lat, d_lon = size_m / 111_320.0, size_m / (111_320.0 * np.cos(np.radians(lat)))
            ring = [[lon, lat], [lon + d_lon, lat], [lon + d_lon, lat + d_lat], [lon, lat + d_lat], [lon, lat]]
            hp = {"type": "Polygon", "coordinates": [ring]}
        applicability = [{"permanent": "YES"}] if rng.random() < 0.5 else [
            {"permanent": "NO", "schedule": [{"day": ["MON", "WED", "SAT"], "startTime": "06:00Z", "endTime": "14:30Z"}]}]
        features.append({
            "identifier": f"Z{i:05d}"[-7:], "country": "CZE", "name": f"zone {i}", "type": "COMMON",
            "restriction": str(rng.choice(["CONDITIONAL", "REQ_AUTHORISATION", "NO_RESTRICTION"])),
            "message": "a test zone", "zoneAuthority": [{"name": "the authority"}], "applicability": applicability,
            "geometry": [{"uomDimensions": "M", "lowerLimit": lower, "lowerVerticalReference": "AGL", "upperLimit": upper,
                          "upperVerticalReference": "AGL", "horizontalProjection": hp}]})
    path.write_text(json.dumps({"title": "benchmark zones", "features": features}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--zones", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    from aerosurvey.airspace.check import check_airspace
    from aerosurvey.airspace.read import read_zone_file
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import mission_programs
    from aerosurvey.spec import load_spec, with_zone_files

    with tempfile.TemporaryDirectory() as tmp:
        zones = Path(tmp) / "zones.json"
        zone_file(zones, args.zones, args.seed, (14.959, 49.4326))
        t0 = time.perf_counter()
        read = read_zone_file(zones)
        t_read = time.perf_counter() - t0
        spec = load_spec(REPO / "missions" / "obratan-72ha.toml")
        assert spec.battery is not None
        from dataclasses import replace

        spec = with_zone_files(spec, [zones])
        # the operator holds every authorisation: the zones advise, none blocks or changes the route
        authorised = tuple(z.identifier for z in read if z.restriction == "REQ_AUTHORISATION")
        spec = replace(spec, battery=replace(spec.battery, usable_min=12.0),
                       airspace=replace(spec.airspace, authorisations=authorised))
        t0 = time.perf_counter()
        plan = plan_from_files(spec)
        t_plan = time.perf_counter() - t0
        programs = mission_programs(plan)
        times = []
        report = None
        for _ in range(3):
            t0 = time.perf_counter()
            report = check_airspace(plan, programs)
            times.append(time.perf_counter() - t0)
        assert report is not None
        waypoints = sum(len(p.waypoints) for p in programs.values())
        print(f"zones: {len(read)} read in {t_read:.2f} s; plan: {len(plan.sorties)} sorties, {len(programs)} flights "
              f"({waypoints} waypoints), planned with the zones in {t_plan:.2f} s")
        print(f"4-D check of every leg: best {min(times):.3f} s of {', '.join(f'{t:.3f}' for t in times)}; "
              f"{len(report.verdicts)} zones near the flights: {len(report.of('block'))} block, "
              f"{len(report.of('advise'))} advise, {len(report.of('neither'))} neither")


if __name__ == "__main__":
    sys.exit(main())
