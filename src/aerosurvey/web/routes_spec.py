"""The page's start and the spec it edits:

  GET    /                 the page
  GET    /api/state        the starting spec, its geometry (WKT), cameras, rule profiles, settings
  POST   /api/area         multipart `file`: an area file, read in memory → a spec over it (area as WKT)
  POST   /api/dem          multipart `file`: a GeoTIFF DEM, checked and stored in the mission's folder → its path
  POST   /api/spec/toml    {"spec": {...}, "zones"?} → the spec as TOML (attachment); a zip of it and the files it names
  POST   /api/spec/save    {"spec": {...}, "zones"?} → written over the spec file the server was started with;
                           a drawn area and drawn zones go to GeoJSON files beside it
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response

from aerosurvey.errors import AerosurveyError
from aerosurvey.web import service
from aerosurvey.web.dem import store_uploaded_dem
from aerosurvey.web.specfile import geometry_preview, save_with_geometry, spec_download
from aerosurvey.web.state import ServerState, attachment, blocking, error, one_file, server, spec_body, zip_texts, zones_body


async def index(request: Request) -> Response:
    return FileResponse(str(resources.files("aerosurvey.web").joinpath("static/index.html")),
                        headers={"Cache-Control": "no-store"})


async def api_state(request: Request) -> Response:
    return JSONResponse(await blocking(_state, server(request)))


def _state(state: ServerState) -> dict[str, Any]:
    """The page's starting point (the camera database and profiles are read from files)."""
    from aerosurvey.camera import database
    from aerosurvey.plan.pattern import field_table
    from aerosurvey.rules.profile import available_profiles

    cams = [{"id": c.id, "name": c.name, "focal_mm": c.focal_mm, "pixel_pitch_um": round(c.pixel_pitch_um, 2)}
            for c in sorted(database().values(), key=lambda c: c.id)]
    profiles = [{"id": p.id, "name": p.name, "rules": len(p.rules)} for p in available_profiles().values()]
    return {"spec": state.spec, "spec_path": str(state.spec_path) if state.spec_path else None, "cameras": cams,
            "profiles": profiles, "patterns": field_table(), "tile_url": state.tile_url, "upload_limit": state.upload_limit,
            "preview": geometry_preview(state.workspace, state.spec),
            # a page without a spec: the settings an area drawn on it starts from
            "defaults": {k: v for k, v in service.default_spec({}, "drawn-area").items() if k != "area"},
            "basemap": state.basemap.info.as_dict() if state.basemap else None,
            "lan": state.shares is not None,
            "campaign": state.campaign.name if state.campaign else None}


async def upload_area(request: Request) -> Response:
    state = server(request)
    try:
        name, data, form = await one_file(request, state.upload_limit, "area upload", "area.file", max_fields=10)
        name = name or "area"
        current = form.get("spec")
        got = await blocking(service.read_uploaded_area, name, data, state.upload_limit // 2)
    except AerosurveyError as exc:
        return error(exc)
    try:
        base_spec = json.loads(current) if isinstance(current, str) and current else state.spec
    except ValueError:
        base_spec = state.spec
    return JSONResponse({"spec": service.with_new_area(base_spec, got.area, Path(name).stem), "file_name": name,
                         "area": {"bounds": list(got.bounds), "vertices": got.vertices}})


async def upload_dem(request: Request) -> Response:
    """A GeoTIFF DEM from the page, stored in the mission's folder (web/dem.py): its path for `terrain.dem`."""
    state = server(request)
    try:
        name, data, _ = await one_file(request, state.upload_limit, "DEM upload", "terrain.dem", max_fields=2)
        return JSONResponse(await blocking(store_uploaded_dem, state.workspace.base, name or "dem.tif", data))
    except AerosurveyError as exc:
        return error(exc)


async def spec_toml(request: Request) -> Response:
    """The spec as a TOML file; a zip of it and the files it names (drawn zones' GeoJSON, the area and zone files)."""
    state = server(request)
    try:
        spec = await spec_body(request)
        zones = await zones_body(request)
        name = Path(str((spec.get("mission") or {}).get("name") or "mission")).name or "mission"
        files = await blocking(spec_download, state.workspace, spec, zones, name)
    except AerosurveyError as exc:
        return error(exc)
    if len(files) == 1:
        return Response(files[f"{name}.toml"], media_type="application/toml",
                        headers=attachment(f"{name}.toml"))
    return Response(await blocking(zip_texts, files), media_type="application/zip",
                    headers=attachment(f"{name}.zip"))


async def spec_save(request: Request) -> Response:
    state = server(request)
    if state.spec_path is None:
        return JSONResponse({"error": "the server was started without a spec file: download the TOML instead", "key": None},
                            status_code=409)
    try:
        spec = await spec_body(request)
        zones = await zones_body(request)
        saved, geometry, preview = await blocking(_save, state, spec, zones)
    except AerosurveyError as exc:
        return error(exc)
    return JSONResponse({"saved": str(state.spec_path), "geometry": geometry, "spec": saved, "preview": preview})


def _save(state: ServerState, spec: dict[str, Any], zones: list[str] | None
          ) -> tuple[dict[str, Any], list[str], dict[str, Any]]:
    assert state.spec_path is not None
    saved, geometry, preview = save_with_geometry(state.workspace, state.spec_path, spec, zones)
    state.spec = service.spec_to_json(saved)
    return state.spec, geometry, preview
