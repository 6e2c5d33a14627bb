"""Flight results over a plan:

  POST   /api/plans/{pid}/flight     multipart files of a `log ingest` folder → flown layers
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

from starlette.datastructures import UploadFile
from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from aerosurvey.errors import AerosurveyError
from aerosurvey.web import service
from aerosurvey.web.state import blocking, error, plan_gone, save_upload, server

#: The files of a `log ingest` folder the page draws; others in the folder are ignored.
FLIGHT_FILES = ("events.csv", "coverage.tif", "log_report.json")


async def flight_results(request: Request) -> Response:
    state = server(request)
    bundle = state.plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    folder = state.workspace.uploads / f"flight-{state.next_serial()}"
    try:
        form = await request.form(max_files=20, max_fields=5)
        uploads = [v for _, v in form.multi_items()
                   if isinstance(v, UploadFile) and v.filename and Path(v.filename).name in FLIGHT_FILES]
        layers = await blocking(_layers, uploads, folder, bundle)
    except AerosurveyError as exc:
        return error(exc)
    finally:
        await blocking(shutil.rmtree, folder, ignore_errors=True)
    return JSONResponse(layers)


def _layers(uploads: list[UploadFile], folder: Path, bundle: service.PlanBundle) -> dict[str, Any]:
    from aerosurvey.web.flown import flown_layers

    files = {Path(u.filename or "").name: save_upload(u, folder) for u in uploads}
    # the plan's manifest: results of another plan are refused by distance and mission name
    return flown_layers(files, bundle.frame, bundle.files["manifest.json"])
