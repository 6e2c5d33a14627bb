"""`aerosurvey plan`: from a mission spec to mission files, manifest and preview."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from aerosurvey import console

if TYPE_CHECKING:
    from aerosurvey.plan.planner import Plan

log = logging.getLogger(__name__)


def summary(plan: Plan, warnings: list[str], rules: list[dict[str, Any]]) -> list[str]:
    e = plan.estimates
    h = plan.heights
    sp = plan.speed
    lines = [
        f"mission {plan.spec.name}: {plan.area.area / 1e4:.2f} ha in {plan.planar.name}, camera {plan.spec.camera.camera.name}",
        f"  height AGL      {h.nominal_agl_m:.1f} m ("
        + ("flat ground, no DEM" if h.mode == "none"
           else f"terrain mode {h.mode}; {h.spacing_agl_m:.1f}..{h.max_agl_m:.1f} m above the ground")
        + ")",
        f"  GSD             {plan.gsd_min_m * 100:.2f}..{plan.gsd_max_m * 100:.2f} cm (target {plan.gsd_target_m * 100:.2f} cm)",
        f"  footprint       {plan.across_m:.1f} m across x {plan.along_m:.1f} m along",
        f"  line spacing    {plan.spacing_m:.1f} m, photo base {plan.base_m:.2f} m"
        + (f", trigger distance {plan.trigger_distance_m:.2f} m" if plan.trigger_distance_m is not None else "")
        + (f", interval {plan.trigger_interval_s:.2f} s" if plan.trigger_interval_s else ""),
        f"  max speed       {sp.speed_ms:.1f} m/s, limited by {sp.reason} (cruise {sp.cruise_ms:.1f}, "
        f"camera cycle {sp.cycle_limit_ms:.1f}, motion blur {sp.blur_limit_ms:.1f} m/s)",
        f"  heading         {plan.heading_deg:.1f} deg ({plan.heading_chosen})"
        + (", cross-hatch at +90 deg" if plan.spec.flight.cross_hatch else ""),
        f"  lines           {len({(r.pass_index, r.line) for r in plan.route.runs})} lines in {len(plan.route.runs)} runs, "
        f"{len(plan.stations.ids)} photos",
        "  route           " + "; ".join(f"pass {i}: {how}" for i, how in enumerate(plan.route.strategy, start=1)),
        f"  flight          {e['total_distance_m'] / 1000:.2f} km, {e['total_time_s'] / 60:.1f} min estimated",
    ]
    battery = plan.spec.battery
    if plan.sorties and battery is not None:  # sorties are split only when a battery is given
        lines.append("  sorties         id   photos  time min  dist km  battery %  first station -> last station")
        st = plan.stations
        for k, (s, _) in enumerate(plan.sorties, start=1):
            pct = 100 * s.battery_used * (1 - battery.reserve)
            lines.append(f"                  S{k:02d} {s.last - s.first + 1:7d} {(s.horizontal_s + s.vertical_s) / 60:9.1f} "
                         f"{s.distance_m / 1000:8.2f} {pct:10.1f}  {st.ids[s.first]} -> {st.ids[s.last]}")
    if plan.sun is not None:
        lines.append(f"  sun elevation   {plan.sun['min_elevation_deg']}..{plan.sun['max_elevation_deg']} deg over the planned window")
    if rules:
        failed = [r for r in rules if r["status"] in ("fail", "warning")]
        lines.append(f"  rules           {len(rules)} evaluated, {len(failed)} failing (`aerosurvey check` for the evidence)")
    for w in warnings:
        lines.append(f"  warning: {w}")
    return lines


@click.command()
@click.argument("spec", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Folder for the mission files, manifest and preview (created if missing).")
def plan(spec: Path, outdir: Path) -> None:
    """Plan a survey mission from a mission spec (TOML) and write its files into OUTDIR."""
    # imported here, not at the top: listing this command in `aerosurvey --help` must not load the planner
    from aerosurvey.inputs import plan_from_files
    from aerosurvey.outputs import write_outputs
    from aerosurvey.spec import load_spec

    t0 = time.perf_counter()
    mission_spec = load_spec(spec)
    with console.progress(f"planning {mission_spec.name}") as report:
        result = plan_from_files(mission_spec, console.part(report, 0.0, 0.85))
        t1 = time.perf_counter()
        report("mission files, rules and preview", 0.85)
        rendered = write_outputs(result, outdir)
    log.info("planned in %.2f s, files written in %.2f s", t1 - t0, time.perf_counter() - t1)
    for line in summary(result, rendered.warnings, rendered.rules):
        click.echo(line)
    click.echo(f"wrote {', '.join(sorted(rendered.files))} to {outdir}")
    failing = [r["rule"] for r in rendered.rules if r["status"] == "fail" and r["severity"] == "error"]
    if failing:  # written so that it can be inspected, but not a plan to fly as it is
        from aerosurvey.errors import CheckFailed

        raise CheckFailed(f"{len(failing)} error-severity rule(s) fail ({', '.join(failing)}): the plan is written to "
                          f"{outdir} for inspection only (`aerosurvey check` for the evidence)")
