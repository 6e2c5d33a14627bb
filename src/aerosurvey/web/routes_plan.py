"""Plans as jobs and a plan's files:

  POST   /api/plan                   {"spec": {...}, "zones": [WKT, ...]?} → 202 {"job": id}; 429 when the queue is full
  GET    /api/jobs/{id}?wait=S       the job's state and progress; when done, the plan's view
  DELETE /api/jobs/{id}              cancel a running plan
  GET    /api/plans/{pid}/files/{n}  one mission file (attachment)
  GET    /api/plans/{pid}/archive.zip  all of them
  POST   /api/plans/{pid}/brief      {"at": ISO 8601 with offset, "battery_change_min"?} → `aerosurvey brief` of the plan
                                     (with `serve --connect`, the vehicle's checks as `brief --connect` makes them)
  POST   /api/plans/{pid}/share/{n}  one file shared on the local network (serve --lan): its URL and QR code
  GET    /lan/{token}/{n}            a shared file, the one request answered to other machines (web/lan.py)
"""

from __future__ import annotations

import asyncio
import datetime as dt
import time
from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from aerosurvey.errors import InputError
from aerosurvey.web import service
from aerosurvey.web.jobs import Progress, QueueFull
from aerosurvey.web.state import attachment, blocking, error, not_found, plan_gone, server, spec_body, zip_texts, zones_body

MAX_WAIT_S = 10.0
_POLL_S = 0.02
_MEDIA = {"json": "application/json", "geojson": "application/geo+json", "kml": "application/vnd.google-earth.kml+xml",
          "svg": "image/svg+xml", "csv": "text/csv", "gpx": "application/gpx+xml", "kmz": "application/vnd.google-earth.kmz"}


async def submit_plan(request: Request) -> Response:
    state = server(request)
    try:
        spec = await spec_body(request)
        zones = await zones_body(request)
    except InputError as exc:
        return error(exc)

    def work(progress: Progress) -> dict[str, Any]:
        bundle = service.plan_bundle(spec, state.workspace, progress, zones)
        return {"plan_id": state.remember(bundle), "files": bundle.names(), **bundle.view}

    try:
        job = state.runner.submit(work)
    except QueueFull as exc:
        return error(exc, 429)
    return JSONResponse({"job": job.id}, status_code=202)


async def job_status(request: Request) -> Response:
    job_id = request.path_params["job_id"]
    job = server(request).runner.get(job_id)
    if job is None:
        return not_found(f"job {job_id!r} is not known (finished long ago?)")
    raw = request.query_params.get("wait", "0")
    try:
        wait = min(max(float(raw), 0.0), MAX_WAIT_S)
    except ValueError:
        return error(InputError(f"wait = {raw!r} is not allowed: seconds from 0 to {MAX_WAIT_S:g}"))
    end = time.monotonic() + wait
    while not job.done.is_set() and time.monotonic() < end:  # a long poll that holds no thread
        await asyncio.sleep(_POLL_S)
    out = job.status()
    if job.state == "done":
        out["result"] = job.result
    return JSONResponse(out)


async def cancel_job(request: Request) -> Response:
    job_id = request.path_params["job_id"]
    job = server(request).runner.cancel(job_id)
    if job is None:
        return not_found(f"job {job_id!r} is not known")
    return JSONResponse(job.status())


async def plan_file(request: Request) -> Response:
    bundle = server(request).plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    name = request.path_params["name"]
    data = bundle.data(name)
    if data is None:
        return not_found(f"the plan has no file {name!r}; it has {', '.join(bundle.names())}")
    return _file_response(name, data)


async def brief(request: Request) -> Response:
    state = server(request)
    bundle = state.plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    try:
        body = await request.json()
        at = dt.datetime.fromisoformat(str(body.get("at"))) if isinstance(body, dict) else None
        change = float(body.get("battery_change_min", 5.0)) if isinstance(body, dict) else -1.0
    except (ValueError, TypeError):
        at, change = None, -1.0
    if at is None or at.tzinfo is None:
        return error(InputError("brief: send {\"at\": a date and time in ISO 8601 with its UTC offset}", key="brief"))
    if not 0.0 <= change <= 120.0:
        return error(InputError("brief: battery_change_min must be a number of minutes from 0 to 120", key="brief"))
    try:
        return JSONResponse(await blocking(service.bundle_brief, bundle, state.workspace, at, change, state.vehicle))
    except InputError as exc:
        return error(exc)


def _file_response(name: str, data: bytes) -> Response:
    return Response(data, media_type=_MEDIA.get(name.rsplit(".", 1)[-1], "text/plain"), headers=attachment(name))


async def share_file(request: Request) -> Response:
    state = server(request)
    if state.shares is None:
        return not_found("files are shared on the local network only when the server runs with `aerosurvey serve --lan`")
    bundle = state.plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    name = request.path_params["name"]
    if bundle.data(name) is None:
        return not_found(f"the plan has no file {name!r}; it has {', '.join(bundle.names())}")
    return JSONResponse(await blocking(state.shares.share, request.path_params["plan_id"], name))


async def lan_file(request: Request) -> Response:
    state = server(request)
    shared = state.shares.get(request.path_params["token"]) if state.shares is not None else None
    if shared is None or shared[1] != request.path_params["name"]:
        return not_found("no file is shared under this address (shares are forgotten when the server stops)")
    bundle = state.plan(shared[0])
    data = bundle.data(shared[1]) if bundle is not None else None
    if data is None:
        return not_found("the shared plan is not kept any more: share its file again from the page")
    return _file_response(shared[1], data)


async def plan_archive(request: Request) -> Response:
    bundle = server(request).plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    data = await blocking(zip_texts, {**bundle.files, **bundle.binary})
    stem = bundle.view["name"] or "mission"
    return Response(data, media_type="application/zip", headers=attachment(f"{stem}.zip"))
