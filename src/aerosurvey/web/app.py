"""The planner's web page: a Starlette app serving a JSON API and the static page.

Endpoints (all JSON unless said otherwise):
  GET    /                           the page
  GET    /api/state                  the starting spec, cameras, rule profiles, settings
  POST   /api/plan                   {"spec": {...}} → 202 {"job": id}; a plan runs as a job
  GET    /api/jobs/{id}?wait=S       the job's state, progress and, when done, the plan's view
  DELETE /api/jobs/{id}              cancel a running plan
  GET    /api/plans/{pid}/files/{n}  a mission file (attachment); /archive.zip for all of them
  POST   /api/area                   multipart `file`: an area file → a spec over it
  POST   /api/spec/toml              {"spec": {...}} → the spec as TOML (attachment)
  POST   /api/spec/save              {"spec": {...}} → written over the spec file the server was started with
  POST   /api/plans/{pid}/flight     multipart files of a `log ingest` folder → flown layers
Errors are {"error": message, "key": spec key or null} with 400 (bad input), 404, 409, 413 or 500.
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import itertools
import shutil
import tempfile
import zipfile
from collections import OrderedDict
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from aerosurvey.errors import AerosurveyError, InputError
from aerosurvey.web import service
from aerosurvey.web.jobs import JobRunner
from aerosurvey.web.limits import BodyLimit, HostCheck

UPLOAD_LIMIT = 50 * 1024 * 1024


@dataclass
class ServerState:
    spec_path: Path | None
    spec: dict[str, Any]
    workspace: service.Workspace
    tile_url: str
    runner: JobRunner
    plans: OrderedDict[str, Any] = field(default_factory=OrderedDict)
    serial: itertools.count = field(default_factory=lambda: itertools.count(1))
    keep_plans: int = 8  # each holds every file of a plan: a large plan is tens of MB

    def remember(self, bundle: service.PlanBundle) -> str:
        pid = f"p{next(self.serial)}"
        self.plans[pid] = bundle
        while len(self.plans) > self.keep_plans:
            self.plans.popitem(last=False)
        return pid


def _error(exc: Exception, status: int = 400) -> JSONResponse:
    return JSONResponse({"error": str(exc), "key": getattr(exc, "key", None)}, status_code=status)


async def _json_body(request: Request) -> dict[str, Any]:
    if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
        raise InputError("request body: send the spec as JSON (Content-Type: application/json)")
    try:
        body = await request.json()
    except ValueError as exc:
        raise InputError(f"request body is not valid JSON: {exc}") from None
    if not isinstance(body, dict) or not isinstance(body.get("spec"), dict):
        raise InputError('request body: expected {"spec": {...}} with the mission spec\'s tables', key="spec")
    return body


def create_app(spec_path: Path | None = None, tile_url: str = "", allowed_hosts: list[str] | None = None,
               upload_limit: int = UPLOAD_LIMIT, workers: int = 2) -> Starlette:
    """The app; `allowed_hosts` None accepts any Host header (tests), else only those (DNS rebinding)."""
    uploads = Path(tempfile.mkdtemp(prefix="aerosurvey-serve-"))
    if spec_path is not None:
        spec_path = spec_path.resolve()
        spec = service.read_spec_file(spec_path)
        base = spec_path.parent
    else:
        spec, base = {}, uploads
    ws = service.Workspace(base=base, uploads=uploads, roots=[base])
    state = ServerState(spec_path, spec, ws, tile_url, JobRunner(workers=workers))

    async def index(request: Request) -> Response:
        return FileResponse(str(resources.files("aerosurvey.web").joinpath("static/index.html")),
                            headers={"Cache-Control": "no-store"})

    async def api_state(request: Request) -> Response:
        from aerosurvey.camera import database
        from aerosurvey.rules.profile import available_profiles

        cams = [{"id": c.id, "name": c.name, "focal_mm": c.focal_mm, "pixel_pitch_um": round(c.pixel_pitch_um, 2)}
                for c in sorted(database().values(), key=lambda c: c.id)]
        profiles = [{"id": p.id, "name": p.name, "rules": len(p.rules)} for p in available_profiles().values()]
        return JSONResponse({"spec": state.spec, "spec_path": str(state.spec_path) if state.spec_path else None,
                             "cameras": cams, "profiles": profiles, "tile_url": state.tile_url,
                             "upload_limit": upload_limit})

    async def api_plan(request: Request) -> Response:
        try:
            body = await _json_body(request)
        except InputError as exc:
            return _error(exc)
        spec = body["spec"]

        def work(progress):
            bundle = service.plan_bundle(spec, ws, progress)
            pid = state.remember(bundle)
            return {"plan_id": pid, "files": sorted(bundle.files), **bundle.view}

        job = state.runner.submit(work)
        return JSONResponse({"job": job.id}, status_code=202)

    async def api_job(request: Request) -> Response:
        job = state.runner.get(request.path_params["job_id"])
        if job is None:
            return JSONResponse({"error": f"job {request.path_params['job_id']!r} is not known (finished long ago?)", "key": None},
                                status_code=404)
        try:
            wait = min(max(float(request.query_params.get("wait", "0")), 0.0), 10.0)
        except ValueError:
            return _error(InputError(f"wait = {request.query_params.get('wait')!r} is not allowed: seconds from 0 to 10"))
        waited = 0.0
        while not job.done.is_set() and waited < wait:
            await asyncio.sleep(0.02)
            waited += 0.02
        out = job.status()
        if job.state == "done":
            out["result"] = job.result
        return JSONResponse(out)

    async def api_cancel(request: Request) -> Response:
        job = state.runner.cancel(request.path_params["job_id"])
        if job is None:
            return JSONResponse({"error": f"job {request.path_params['job_id']!r} is not known", "key": None}, status_code=404)
        return JSONResponse(job.status())

    def _bundle(request: Request) -> service.PlanBundle | None:
        return state.plans.get(request.path_params["plan_id"])

    async def api_file(request: Request) -> Response:
        bundle = _bundle(request)
        name = request.path_params["name"]
        if bundle is None:
            return JSONResponse({"error": f"plan {request.path_params['plan_id']!r} is not kept any more: plan again", "key": None},
                                status_code=404)
        if name not in bundle.files:
            return JSONResponse({"error": f"the plan has no file {name!r}; it has {', '.join(sorted(bundle.files))}", "key": None},
                                status_code=404)
        media = {"json": "application/json", "geojson": "application/geo+json", "kml": "application/vnd.google-earth.kml+xml",
                 "svg": "image/svg+xml", "csv": "text/csv", "gpx": "application/gpx+xml"}.get(name.rsplit(".", 1)[-1], "text/plain")
        return Response(bundle.files[name].encode("utf-8"), media_type=media,
                        headers={"Content-Disposition": f'attachment; filename="{name}"'})

    async def api_archive(request: Request) -> Response:
        bundle = _bundle(request)
        if bundle is None:
            return JSONResponse({"error": f"plan {request.path_params['plan_id']!r} is not kept any more: plan again", "key": None},
                                status_code=404)
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
            for name, text in sorted(bundle.files.items()):
                zf.writestr(name, text)
        stem = bundle.view["name"] or "mission"
        return Response(buf.getvalue(), media_type="application/zip",
                        headers={"Content-Disposition": f'attachment; filename="{stem}.zip"'})

    async def _save_upload(upload, folder: Path) -> Path:
        folder.mkdir(parents=True, exist_ok=True)
        target = folder / Path(upload.filename or "upload").name
        with open(target, "wb") as fh:
            while chunk := await upload.read(1 << 20):
                fh.write(chunk)
        return target

    async def api_area(request: Request) -> Response:
        try:
            form = await request.form(max_files=1, max_fields=10)
        except AerosurveyError as exc:
            return _error(exc)
        upload = form.get("file")
        if upload is None or isinstance(upload, str):
            return _error(InputError("area upload: send the area file as the multipart field 'file'", key="area.file"))
        serial = next(state.serial)
        try:
            tmp = await _save_upload(upload, uploads / f"incoming-{serial}")
            path = service.store_upload(ws, upload.filename or "area", tmp, serial)
            info = await asyncio.to_thread(service.validate_area, path)
        except AerosurveyError as exc:
            return _error(exc)
        finally:
            shutil.rmtree(uploads / f"incoming-{serial}", ignore_errors=True)
        current = form.get("spec")
        import json as _json

        try:
            base_spec = _json.loads(current) if isinstance(current, str) and current else state.spec
        except ValueError:
            base_spec = state.spec
        name = Path(upload.filename or "area").stem
        return JSONResponse({"spec": service.with_new_area(base_spec, str(path), name), "area": info,
                             "file_name": Path(upload.filename or "area").name})

    async def api_spec_toml(request: Request) -> Response:
        try:
            body = await _json_body(request)
            text = await asyncio.to_thread(_validated_toml, body["spec"])
        except AerosurveyError as exc:
            return _error(exc)
        name = str((body["spec"].get("mission") or {}).get("name") or "mission")
        return Response(text.encode("utf-8"), media_type="application/toml",
                        headers={"Content-Disposition": f'attachment; filename="{name}.toml"'})

    def _validated_toml(spec: dict[str, Any]) -> str:
        from aerosurvey.spec import parse_spec

        ws.check_paths(spec)
        parse_spec(spec, base=ws.base, path=None)
        return service.spec_to_toml(_relative_paths(spec))

    def _relative_paths(spec: dict[str, Any]) -> dict[str, Any]:
        """Paths inside the spec's folder are written relative to it, as a hand-written spec has them."""
        import copy

        out = copy.deepcopy(spec)
        for table, key in service.PATH_KEYS:
            v = (out.get(table) or {}).get(key)
            if isinstance(v, str):
                out[table][key] = _rel(v)
        ex = (out.get("area") or {}).get("exclusions")
        if isinstance(ex, list):
            out["area"]["exclusions"] = [_rel(v) if isinstance(v, str) else v for v in ex]
        return out

    def _rel(v: str) -> str:
        p = ws.resolve(v).resolve()
        try:
            return p.relative_to(ws.base.resolve()).as_posix()
        except ValueError:
            return str(p)

    async def api_spec_save(request: Request) -> Response:
        if state.spec_path is None:
            return JSONResponse({"error": "the server was started without a spec file: download the TOML instead", "key": None},
                                status_code=409)
        try:
            body = await _json_body(request)
            text = await asyncio.to_thread(_validated_toml, body["spec"])
        except AerosurveyError as exc:
            return _error(exc)
        from aerosurvey.fileio import atomic_write_text

        atomic_write_text(state.spec_path, text)
        state.spec = service.spec_to_json(body["spec"])
        return JSONResponse({"saved": str(state.spec_path), "bytes": len(text.encode("utf-8"))})

    async def api_flight(request: Request) -> Response:
        bundle = _bundle(request)
        if bundle is None:
            return JSONResponse({"error": f"plan {request.path_params['plan_id']!r} is not kept any more: plan again", "key": None},
                                status_code=404)
        serial = next(state.serial)
        folder = uploads / f"flight-{serial}"
        try:
            form = await request.form(max_files=20, max_fields=5)
            files: dict[str, Path] = {}
            for _, v in form.multi_items():
                if not isinstance(v, str) and v.filename:
                    name = Path(v.filename).name
                    if name in ("events.csv", "coverage.tif", "log_report.json"):
                        files[name] = await _save_upload(v, folder)
            from aerosurvey.web.flown import flown_layers

            layers = await asyncio.to_thread(flown_layers, files, bundle.frame)
        except AerosurveyError as exc:
            return _error(exc)
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        return JSONResponse(layers)

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette):
        try:
            yield
        finally:
            state.runner.shutdown()
            shutil.rmtree(uploads, ignore_errors=True)

    static = StaticFiles(directory=str(resources.files("aerosurvey.web").joinpath("static")))
    routes = [
        Route("/", index),
        Route("/api/state", api_state),
        Route("/api/plan", api_plan, methods=["POST"]),
        Route("/api/jobs/{job_id}", api_job, methods=["GET"]),
        Route("/api/jobs/{job_id}", api_cancel, methods=["DELETE"]),
        Route("/api/plans/{plan_id}/files/{name}", api_file),
        Route("/api/plans/{plan_id}/archive.zip", api_archive),
        Route("/api/plans/{plan_id}/flight", api_flight, methods=["POST"]),
        Route("/api/area", api_area, methods=["POST"]),
        Route("/api/spec/toml", api_spec_toml, methods=["POST"]),
        Route("/api/spec/save", api_spec_save, methods=["POST"]),
        Mount("/static", static),
    ]
    app = Starlette(routes=routes, lifespan=lifespan)
    app.add_middleware(BodyLimit, limit=upload_limit)
    app.add_middleware(HostCheck, allowed_hosts=allowed_hosts)
    app.state.server = state
    return app
