"""Flight programs and their emitters on the three examples, against planning them, same process.

    python benchmarks/program_bench.py

For each example: the planning time (plan_from_files, the baseline), then the median of 3
runs of building every flight program (the mission and each sortie), the final gate on them,
the MAVLink missions with their .waypoints and .plan texts, and the DJI .kmz of every flight
(for the M3E, whatever the example's camera; a flight DJI refuses is counted as refused).
Prints each as a ratio of the planning time, and the sizes: waypoints, MAVLink items, .kmz
bytes; then the same example flown as hover-and-shoot (camera.trigger = "hover", 2 s), whose
MAVLink item count is set against the autopilot's limit. Not covered: reading the files back,
the rest of `plan`'s outputs (manifest, preview, GeoJSON), DJI Pilot 2 itself.
"""

from __future__ import annotations

import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = ("forest-dem", "kubad-abad-fixed-wing", "obratan-72ha")


def _median(fn, n: int = 3) -> tuple[float, object]:
    times, out = [], None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main() -> None:
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.mission.builder import mavlink_mission
    from aerosurvey.mission.formats import wpml
    from aerosurvey.mission.formats.qgc_plan import dumps_plan
    from aerosurvey.mission.formats.wpl import dumps_wpl
    from aerosurvey.mission.program import flight_program
    from aerosurvey.mission.targets import M3E, mavlink_item_limit
    from aerosurvey.outputs import final_gate
    from aerosurvey.spec import load_spec

    for ex in EXAMPLES:
        t0 = time.perf_counter()
        plan = plan_from_files(load_spec(REPO / "missions" / f"{ex}.toml"))
        t_plan = time.perf_counter() - t0
        flights = [None, *range(len(plan.sorties))]

        def programs(plan=plan, flights=flights):
            return {k: flight_program(plan, k) for k in flights}

        t_prog, progs = _median(programs)
        t_gate, _ = _median(lambda progs=progs, plan=plan: final_gate(plan, {str(k): p for k, p in progs.items()}))

        def mavlink(progs=progs):
            ms = [mavlink_mission(p) for p in progs.values()]
            return ms, [dumps_wpl(m) + dumps_plan(m) for m in ms]

        t_mav, (missions, _) = _median(mavlink)

        def kmz(progs=progs):
            return [wpml.kmz_bytes(p, M3E) if wpml.refusal(p) is None else None for p in progs.values()]

        t_kmz, kmzs = _median(kmz)
        n_wp = sum(len(p.waypoints) for p in progs.values())
        n_items = sum(len(m.items) for m in missions)
        made = [k for k in kmzs if k is not None]
        refused = [wpml.refusal(p) for p in progs.values() if wpml.refusal(p) is not None]
        print(f"{ex}: {len(flights)} flights, {n_wp} waypoints, {n_items} MAVLink items, planned in {t_plan:.2f} s")
        print(f"  programs {t_prog / t_plan:.3f}x, gate {t_gate / t_plan:.3f}x, MAVLink + texts {t_mav / t_plan:.3f}x, "
              f"kmz {t_kmz / t_plan:.3f}x of the planning time; {len(made)} kmz, {sum(map(len, made))} bytes"
              + (f"; refused: {refused[0]}" if refused else ""))
        hover = replace(plan, camera=replace(plan.camera, trigger="hover", settle_s=2.0))
        if plan.vehicle.type == "copter":
            whole = mavlink_mission(flight_program(hover))
            limit = mavlink_item_limit(plan.vehicle.firmware, plan.battery)
            print(f"  hover and shoot: {len(whole.items) + 1} items in the whole mission (home included) "
                  f"against {limit} ({plan.vehicle.firmware}); {len(plan.stations.ids)} stations")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
