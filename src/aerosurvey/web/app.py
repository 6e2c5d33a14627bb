"""The planner's web page: a Starlette app serving a JSON API and the static page.

Endpoints (all JSON unless said otherwise), each a small handler in a module of its own:
  GET    /                           the page                                   (routes_spec)
  GET    /api/state                  the starting spec, cameras, rule profiles, settings
  POST   /api/area                   multipart `file`: an area file, read in memory → a spec over it (area as WKT)
  POST   /api/dem                    multipart `file`: a GeoTIFF DEM, checked, stored in the mission's folder → its path
  POST   /api/spec/toml              {"spec": {...}} → the spec as TOML (attachment); a zip with the files it names
  POST   /api/spec/save              {"spec": {...}} → written over the spec file the server was started with
  POST   /api/plan                   {"spec": {...}} → 202 {"job": id}; a plan runs as a job  (routes_plan)
  GET    /api/jobs/{id}?wait=S       the job's state, progress and, when done, the plan's view
  DELETE /api/jobs/{id}              cancel a running plan
  GET    /api/plans/{pid}/files/{n}  a mission file (attachment); /archive.zip for all of them
  POST   /api/plans/{pid}/flight     multipart files of a `log ingest` folder → flown layers  (routes_flight)
  POST   /api/plans/{pid}/refly      the same files → the re-fly mission of what was not photographed
  POST   /api/plans/{pid}/resume     the same files → the rest of a flight cut short
  GET    /api/basemap/{z}/{x}/{y}    a tile of the offline basemap file (--basemap)            (routes_basemap)
  GET    /api/campaign               the campaign's blocks by status (--campaign), read-only   (routes_campaign)
  GET    /api/campaign/blocks/{name} a block's plan from its folder; /files/{file} one of its files
  GET    /api/vehicle                the vehicle of `serve --connect` (routes_vehicle)
  POST   /api/plans/{pid}/vehicle/{n}  {"send": bool} → 202 {"job": id}: a mission file checked against it, or uploaded
Errors are {"error": message, "key": spec key or null} with 400 (bad input), 403 (another origin), 404, 409,
413 (too large), 421 (another host), 429 (too many plans waiting) or 500.
Handlers run on the event loop; file I/O and computing run on worker threads.
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import AsyncIterator
from importlib import resources
from pathlib import Path

from starlette.applications import Starlette
from starlette.routing import BaseRoute, Mount, Route
from starlette.staticfiles import StaticFiles

from aerosurvey.web import routes_basemap, routes_campaign, routes_flight, routes_plan, routes_spec, routes_vehicle, service
from aerosurvey.web.basemap import open_basemap
from aerosurvey.web.jobs import JobRunner
from aerosurvey.web.lan import LanGate, Shares
from aerosurvey.web.limits import BodyLimit, HostCheck
from aerosurvey.web.state import ServerState, blocking
from aerosurvey.web.vehicle import VehicleLink

UPLOAD_LIMIT = 50 * 1024 * 1024

ROUTES: list[BaseRoute] = [
    Route("/", routes_spec.index),
    Route("/api/state", routes_spec.api_state),
    Route("/api/area", routes_spec.upload_area, methods=["POST"]),
    Route("/api/dem", routes_spec.upload_dem, methods=["POST"]),
    Route("/api/spec/toml", routes_spec.spec_toml, methods=["POST"]),
    Route("/api/spec/save", routes_spec.spec_save, methods=["POST"]),
    Route("/api/plan", routes_plan.submit_plan, methods=["POST"]),
    Route("/api/jobs/{job_id}", routes_plan.job_status, methods=["GET"]),
    Route("/api/jobs/{job_id}", routes_plan.cancel_job, methods=["DELETE"]),
    Route("/api/plans/{plan_id}/files/{name}", routes_plan.plan_file),
    Route("/api/plans/{plan_id}/archive.zip", routes_plan.plan_archive),
    Route("/api/plans/{plan_id}/share/{name}", routes_plan.share_file, methods=["POST"]),
    Route("/api/plans/{plan_id}/brief", routes_plan.brief, methods=["POST"]),
    Route("/lan/{token}/{name}", routes_plan.lan_file, methods=["GET", "HEAD"]),
    Route("/api/plans/{plan_id}/flight", routes_flight.flight_results, methods=["POST"]),
    Route("/api/plans/{plan_id}/refly", routes_flight.refly, methods=["POST"]),
    Route("/api/plans/{plan_id}/resume", routes_flight.resume, methods=["POST"]),
    Route("/api/basemap/{z}/{x}/{y}", routes_basemap.tile),
    Route("/api/campaign", routes_campaign.campaign),
    Route("/api/campaign/blocks/{name}", routes_campaign.block),
    Route("/api/campaign/blocks/{name}/files/{file}", routes_campaign.file),
    Route("/api/vehicle", routes_vehicle.vehicle_state),
    Route("/api/plans/{plan_id}/vehicle/{name}", routes_vehicle.vehicle_submit, methods=["POST"]),
]


def create_app(spec_path: Path | None = None, tile_url: str = "", allowed_hosts: list[str] | None = None,
               upload_limit: int = UPLOAD_LIMIT, workers: int = 2, basemap: Path | None = None,
               lan: str | None = None, campaign: Path | None = None, vehicle: str | None = None) -> Starlette:
    """The app; `allowed_hosts` None accepts any Host header (tests), else only those (DNS rebinding).
    `basemap`: a local .mbtiles or .pmtiles file of raster or vector tiles the page draws under the plan.
    `lan`: "ADDRESS:PORT" on the local network where shared files are served to other machines, and
    nothing else (web/lan.py); None: nothing is shared. `campaign`: a campaign folder whose blocks the page shows
    (read-only; its register is read here first, so a folder that is not one is refused at the start).
    `vehicle`: the pymavlink connection of the vehicle the page checks and uploads to (web/vehicle.py);
    None: no vehicle."""
    spec = {}
    if spec_path is not None:
        spec_path = spec_path.resolve()
        spec = service.read_spec_file(spec_path)
    tiles = open_basemap(basemap) if basemap is not None else None
    if campaign is not None:
        from aerosurvey.campaign.register import read_register

        campaign = campaign.resolve()
        read_register(campaign)
    uploads = Path(tempfile.mkdtemp(prefix="aerosurvey-serve-"))
    base = spec_path.parent if spec_path is not None else uploads
    ws = service.Workspace(base=base, uploads=uploads, roots=[base], spec_file=spec_path)
    state = ServerState(spec_path, spec, ws, tile_url, JobRunner(workers=workers), upload_limit, tiles,
                        shares=Shares(f"http://{lan}") if lan is not None else None, campaign=campaign,
                        vehicle=VehicleLink(vehicle) if vehicle is not None else None)

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        try:
            yield
        finally:  # waiting for running jobs and deleting the uploads block: worker threads
            await blocking(state.runner.shutdown)
            await blocking(shutil.rmtree, uploads, ignore_errors=True)
            if tiles is not None:
                tiles.close()

    static = StaticFiles(directory=str(resources.files("aerosurvey.web").joinpath("static")))
    app = Starlette(routes=[*ROUTES, Mount("/static", static)], lifespan=lifespan)
    app.add_middleware(BodyLimit, limit=upload_limit)
    app.add_middleware(HostCheck, allowed_hosts=allowed_hosts if allowed_hosts is None or lan is None else [*allowed_hosts, lan])
    if lan is not None:  # outermost: another machine reaches nothing but the shared files
        app.add_middleware(LanGate, lan_host=lan)
    app.state.server = state
    return app
