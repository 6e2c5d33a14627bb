"""The vehicle the server was started with (`aerosurvey serve --connect URL`):

  GET    /api/vehicle                      {"url": the connection or null}
  POST   /api/plans/{pid}/vehicle/{name}   {"send": false} → 202 {"job": id}: the checks only (nothing sent);
                                           {"send": true} → 202 {"job": id}: checked, uploaded, read back, compared
Both run as jobs (GET /api/jobs/{id} for their progress and result); nothing reaches the vehicle but by a
POST, which the Host and Origin rules guard as every state-changing request (web/limits.py).
"""

from __future__ import annotations

from typing import Any

from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from aerosurvey.errors import InputError
from aerosurvey.web.jobs import Progress, QueueFull
from aerosurvey.web.state import error, not_found, plan_gone, server
from aerosurvey.web.vehicle import vehicle_job


async def vehicle_state(request: Request) -> Response:
    link = server(request).vehicle
    return JSONResponse({"url": link.url if link is not None else None})


async def vehicle_submit(request: Request) -> Response:
    state = server(request)
    link, bundle = state.vehicle, state.plan(request.path_params["plan_id"])
    if link is None:
        return not_found("no vehicle: start the server with `aerosurvey serve --connect URL` (a pymavlink connection)")
    if bundle is None:
        return plan_gone(request)
    try:
        body = await request.json()
    except ValueError:
        body = None
    send = body.get("send") if isinstance(body, dict) else None
    if not isinstance(send, bool):
        return error(InputError("vehicle: send {\"send\": false} to check the vehicle, {\"send\": true} to upload",
                                key="vehicle"))
    name, scratch = request.path_params["name"], state.workspace.uploads

    def work(progress: Progress) -> dict[str, Any]:
        return vehicle_job(link, bundle, name, scratch, send, progress)

    try:
        job = state.runner.submit(work)
    except QueueFull as exc:
        return error(exc, 429)
    return JSONResponse({"job": job.id}, status_code=202)
