"""manifest.json: the record of a plan that every later step links to by id.

Schema documented in docs/manifest.md; bump SCHEMA_VERSION on any incompatible change.
The manifest holds no time stamp and no absolute path, so the same spec and input files
give a byte-identical manifest.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from aerosurvey import __version__
from aerosurvey.mission.builder import run_id
from aerosurvey.plan.planner import Plan

SCHEMA = "aerosurvey-manifest"
SCHEMA_VERSION = 1


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _f(v: float, nd: int = 3) -> float | None:
    v = float(v)
    return None if not math.isfinite(v) else round(v, nd)


def _lonlat(plan: Plan, xy: tuple[float, float]) -> list[float | None]:
    lon, lat = plan.planar.lonlat(np.array([xy[0]]), np.array([xy[1]]))
    return [_f(lon[0], 8), _f(lat[0], 8)]


def _sorties(plan: Plan) -> list[dict[str, Any]]:
    st = plan.stations
    out = []
    for k, (s, wps) in enumerate(plan.sorties, start=1):
        site = plan.launch_sites[s.launch]
        out.append({
            "id": f"S{k:02d}", "files": [f"sortie-{k:02d}.plan", f"sortie-{k:02d}.waypoints"],
            "launch": {"index": s.launch + 1, "lon": _f(site.lon, 8), "lat": _f(site.lat, 8), "ground_amsl_m": _f(site.ground_m, 2)},
            "first_station": st.ids[s.first], "last_station": st.ids[s.last], "photos": s.last - s.first + 1,
            "time_s": _f(s.horizontal_s + s.vertical_s, 1),
            "time_with_wind_allowance_s": _f(s.horizontal_s * plan.battery.wind_factor + s.vertical_s, 1),
            "distance_m": _f(s.distance_m, 1),
            "battery_used_pct": _f(100 * s.battery_used * (1 - plan.spec.battery.reserve), 1),
            "usable_used_pct": _f(100 * s.battery_used, 1), "mission_items": s.items + 1,
        })
    return out


def _input(path: Path | None, base: Path) -> dict[str, Any] | None:
    if path is None:
        return None
    try:
        rel = path.resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        rel = path.name
    return {"path": rel, "sha256": sha256_file(path)}


def build_manifest(plan: Plan, mission_items: int, outputs: dict[str, str]) -> dict[str, Any]:
    """The manifest as plain JSON data. `outputs` maps each written file name to its sha256."""
    spec = plan.spec
    base = spec.path.parent if spec.path else Path(".")
    cam = spec.camera.camera
    st = plan.stations
    h = plan.heights
    lines = []
    for i, r in enumerate(plan.route.runs):
        sel = np.flatnonzero(st.run == i)
        lines.append({
            "id": run_id(plan, i), "line": f"P{r.pass_index}-L{r.line + 1:03d}", "pass": r.pass_index,
            "order": i + 1, "heading_deg": _f(r.heading_deg), "photos": int(len(sel)),
            "first_station": st.ids[sel[0]], "last_station": st.ids[sel[-1]],
            "lead_in": _lonlat(plan, r.lead_in_xy),
            "end": _lonlat(plan, r.end_xy),
        })
    gsd_cm = st.agl_m * cam.pixel_pitch_mm / cam.focal_mm * 100

    def col(a: np.ndarray, nd: int) -> list[float | None]:
        r = np.round(np.asarray(a, float), nd)
        return [None if not math.isfinite(v) else v for v in r.tolist()]

    columns = zip(st.ids, [run_id(plan, int(r)) for r in st.run], col(st.x, 3), col(st.y, 3), col(st.lon, 8),
                  col(st.lat, 8), col(st.ground_m, 2), col(st.alt_rel_m, 2), col(st.agl_m, 2), col(gsd_cm, 3),
                  col(st.heading_deg, 3))
    stations = [
        {"id": sid, "seq": j + 1, "line": line, "x": x, "y": y, "lon": lon, "lat": lat, "ground_m": g,
         "alt_rel_m": a, "agl_m": agl, "gsd_cm": gsd, "heading_deg": hd}
        for j, (sid, line, x, y, lon, lat, g, a, agl, gsd, hd) in enumerate(columns)
    ]
    inputs = {
        "spec": _input(spec.path, base) if spec.path else None,
        "area": _input(spec.area.file, base) if spec.area.file else {"wkt": spec.area.wkt, "crs": spec.area.wkt_crs},
        "exclusions": [_input(p, base) for p in spec.area.exclusions],
        "dem": _input(spec.terrain.dem, base),
    }
    return {
        "schema": SCHEMA,
        "schema_version": SCHEMA_VERSION,
        "aerosurvey_version": __version__,
        "mission": {"name": spec.name, "vehicle": spec.vehicle.type, "firmware": spec.vehicle.firmware,
                    "profiles": list(spec.profiles)},
        "rule_overrides": dict(sorted(spec.rule_overrides.items())),
        "inputs": inputs,
        "crs": {"planning": plan.planar.name, "geographic": "EPSG:4326"},
        "camera": {"id": cam.id, "name": cam.name, "sensor_mm": [cam.sensor_width_mm, cam.sensor_height_mm],
                   "image_px": [cam.image_width_px, cam.image_height_px], "focal_mm": cam.focal_mm,
                   "pixel_pitch_um": _f(cam.pixel_pitch_um, 4), "mount": spec.camera.mount,
                   "trigger": spec.camera.trigger, "min_cycle_s": spec.camera.min_cycle_s,
                   "exposure_s": spec.camera.exposure_s, "source": cam.source},
        "targets": {"gsd_cm": _f(plan.gsd_target_m * 100, 4), "forward_overlap": spec.targets.forward_overlap,
                    "side_overlap": spec.targets.side_overlap,
                    "images_beyond_boundary": spec.targets.images_beyond_boundary,
                    "coverage_margin_m": spec.targets.coverage_margin_m,
                    "max_height_agl_m": spec.vehicle.max_height_agl_m},
        "derived": {
            "height_agl_m": _f(h.nominal_agl_m), "height_for_gsd_m": _f(h.target_agl_m),
            "lowest_agl_m": _f(h.spacing_agl_m), "highest_agl_m": _f(h.max_agl_m),
            "gsd_min_cm": _f(plan.gsd_min_m * 100, 4), "gsd_max_cm": _f(plan.gsd_max_m * 100, 4),
            "footprint_across_m": _f(plan.across_m), "footprint_along_m": _f(plan.along_m),
            "line_spacing_m": _f(plan.spacing_m), "photo_base_m": _f(plan.base_m),
            "trigger_distance_m": _f(plan.trigger_distance_m) if plan.trigger_distance_m is not None else None,
            "side_images_per_point": plan.side_images_per_point,
            "forward_images_per_point": plan.forward_images_per_point,
            "speed_ms": _f(plan.speed.speed_ms), "speed_reason": plan.speed.reason,
            "speed_limits_ms": {"cruise": _f(plan.speed.cruise_ms), "camera_cycle": _f(plan.speed.cycle_limit_ms),
                                "motion_blur": _f(plan.speed.blur_limit_ms)},
            "trigger_interval_s": _f(plan.trigger_interval_s) if plan.trigger_interval_s else None,
            "lead_in_m": _f(plan.lead_in_m), "turn_radius_m": _f(plan.turn_radius_m),
            "heading_deg": _f(plan.heading_deg), "heading_chosen": plan.heading_chosen,
            "cross_hatch": spec.flight.cross_hatch, "exclusion_margin_m": spec.flight.exclusion_margin_m,
            "route_strategy": list(plan.route.strategy),
            "altitude_frame": plan.altitude_frame,
            "terrain": {"mode": h.mode, "ground_min_m": _f(h.ground_min_m) if h.ground_min_m is not None else None,
                        "ground_max_m": _f(h.ground_max_m) if h.ground_max_m is not None else None,
                        "fixed_alt_amsl_m": _f(h.fixed_alt_amsl_m) if h.fixed_alt_amsl_m is not None else None,
                        "tolerance_m": spec.terrain.tolerance_m},
            "area_ha": _f(plan.area.area / 1e4, 4),
            "grid_scale": round(plan.grid_scale, 9),
        },
        "home": {"lon": _f(plan.home[0], 8), "lat": _f(plan.home[1], 8), "ground_amsl_m": _f(plan.home[2], 2)},
        "estimates": {k: (_f(v, 1) if k != "photos" else int(v)) for k, v in plan.estimates.items()},
        "conditions": plan.sun,
        "sorties": _sorties(plan),
        "lines": lines,
        "stations": stations,
        "mission_items": mission_items,
        "outputs": dict(sorted(outputs.items())),
        "battery": None if plan.spec.battery is None else {
            "usable_min": plan.spec.battery.usable_min, "capacity_wh": plan.spec.battery.capacity_wh,
            "cruise_power_w": plan.spec.battery.cruise_power_w, "climb_power_w": plan.spec.battery.climb_power_w,
            "reserve": plan.spec.battery.reserve, "wind_ms": plan.spec.battery.wind_ms,
            "max_mission_items": plan.spec.battery.max_mission_items},
        "warnings": list(plan.warnings),
    }


def dumps(manifest: dict[str, Any]) -> str:
    """JSON with one top-level key per line and one line or station per line: readable,
    diff-friendly, and written by json's C encoder (an `indent` would fall back to Python)."""
    enc = json.JSONEncoder(ensure_ascii=False, allow_nan=False, separators=(", ", ": "))
    out = ["{"]
    keys = list(manifest)
    for i, key in enumerate(keys):
        value = manifest[key]
        comma = "," if i < len(keys) - 1 else ""
        if isinstance(value, list) and value and isinstance(value[0], dict):
            rows = ",\n  ".join(enc.encode(v) for v in value)
            out.append(f"{enc.encode(key)}: [\n  {rows}\n]{comma}")
        else:
            out.append(f"{enc.encode(key)}: {enc.encode(value)}{comma}")
    out.append("}")
    return "\n".join(out) + "\n"
