"""Flight results over a plan, and the re-fly they lead to:

  POST   /api/plans/{pid}/flight     multipart files of a `log ingest` folder → flown layers
  POST   /api/plans/{pid}/refly      the same files → the re-fly mission (`aerosurvey refly`) and its files
  POST   /api/plans/{pid}/resume     the same files → the rest of the flight (`aerosurvey resume --log`), its files and routes
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from starlette.datastructures import UploadFile
from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from aerosurvey.errors import AerosurveyError, InputError
from aerosurvey.rules.flown import PLACES_FILE
from aerosurvey.web import service
from aerosurvey.web.flown import MIN_GAP_M2, flown_layers
from aerosurvey.web.state import ServerState, blocking, error, plan_gone, save_upload, server

if TYPE_CHECKING:
    from aerosurvey.plan.planner import Plan

#: The files of a `log ingest` folder the page reads (failing_places.geojson: `aerosurvey check FOLDER`); others are ignored.
FLIGHT_FILES = ("events.csv", "coverage.tif", "log_report.json", PLACES_FILE)


async def _on_flight_files(request: Request, work: Callable[[service.PlanBundle, Path, dict[str, Path]], dict[str, Any]]
                          ) -> Response:
    """Save the uploaded files of a `log ingest` folder in a scratch folder, run `work(plan, folder, files)`
    on a worker thread, answer its JSON, remove the folder."""
    state = server(request)
    bundle = state.plan(request.path_params["plan_id"])
    if bundle is None:
        return plan_gone(request)
    folder = state.workspace.uploads / f"flight-{state.next_serial()}"
    try:
        form = await request.form(max_files=20, max_fields=5)
        uploads = [v for _, v in form.multi_items()
                   if isinstance(v, UploadFile) and v.filename and Path(v.filename).name in FLIGHT_FILES]
        files = await blocking(lambda: {Path(u.filename or "").name: save_upload(u, folder) for u in uploads})
        out = await blocking(work, bundle, folder, files)
    except AerosurveyError as exc:
        return error(exc)
    finally:
        await blocking(shutil.rmtree, folder, ignore_errors=True)
    return JSONResponse(out)


async def flight_results(request: Request) -> Response:
    return await _on_flight_files(request, _layers)


async def refly(request: Request) -> Response:
    state = server(request)
    return await _on_flight_files(request, lambda bundle, folder, files: _refly(state, bundle, folder, files))


async def resume(request: Request) -> Response:
    state = server(request)
    return await _on_flight_files(request, lambda bundle, folder, files: _resume(state, bundle, folder, files))


def _layers(bundle: service.PlanBundle, folder: Path, files: dict[str, Path]) -> dict[str, Any]:
    # the plan's manifest: results of another plan are refused by distance and mission name
    return flown_layers(files, bundle.frame, bundle.manifest, bundle.plan_view)


def _refly(state: ServerState, bundle: service.PlanBundle, folder: Path, files: dict[str, Path]) -> dict[str, Any]:
    """`aerosurvey refly` over the uploaded folder, with the saved spec file the page's plan was made from."""
    from aerosurvey.flight.refly import plan_refly

    if bundle.plan_view is None:
        raise InputError("refly: a resumed flight has no plan of its own to re-fly; load the results on the plan", key="refly")
    if state.spec_path is None or bundle.zones is not None or service.spec_to_json(bundle.spec) != state.spec:
        raise InputError("refly: the re-fly is planned from the saved spec file, as `aerosurvey refly --spec` does, and the "
                         "plan on the page is not that of a saved spec: save the spec, let the page plan, then make the re-fly",
                         key="refly")
    for name in ("events.csv", "coverage.tif"):
        if name not in files:
            raise InputError(f"refly: {name} is missing among the loaded files; load the folder `aerosurvey log ingest "
                             "--plan` wrote", key="refly")
    r = plan_refly(folder, bundle.plan_view, state.spec_path, MIN_GAP_M2)
    if r.plan is None:
        return {"plan_id": None, "files": [], "notes": list(r.notes),
                "summary": f"no gaps: every cell of the area is seen by at least {r.need} flown photos; nothing to re-fly"}
    import shapely

    name = r.plan.name
    manifest, features, view = service.plan_documents(r.files, "the re-fly")
    pid = state.remember(service.PlanBundle({"name": name}, dict(r.files), bundle.frame, manifest=manifest, plan_view=view,
                                            binary=dict(r.binary)))
    plan = r.plan
    lines = [f for f in features["features"] if f["properties"]["role"] == "line"]
    return {"plan_id": pid, "files": sorted({*r.files, *r.binary}), "notes": list(r.notes),
            "lines": {"type": "FeatureCollection", "features": lines}, "gaps": json.loads(r.files["gaps.geojson"]),
            "summary": f"{shapely.area(r.gaps) / 1e4:.3f} ha in {len(shapely.get_parts(r.gaps))} gap(s) seen by fewer than "
                       f"{r.need} photos; re-fly {name}: {len(plan.route.runs)} runs, {len(plan.stations.ids)} photos, "
                       f"{plan.estimates['total_time_s'] / 60:.1f} min"}


def _resume(state: ServerState, bundle: service.PlanBundle, folder: Path, files: dict[str, Path]) -> dict[str, Any]:
    """`aerosurvey resume --log` over the uploaded folder: the page's plan (its spec and drawn zones, in
    memory) flown on from the first station the flight did not photograph as the mission asked."""
    from aerosurvey.flight.resume import resume_files, resumed_text
    from aerosurvey.flight.resume_start import start_from_log

    doc = bundle.manifest
    if doc is None:
        raise InputError("resume: a resumed flight is resumed from its plan; load the results on the plan", key="resume")
    try:
        start = start_from_log(folder, doc)
        spec, inputs = service.spec_and_inputs(bundle.spec, state.workspace, bundle.zones)
        plan, out = resume_files(spec, inputs, start, doc, "the page's plan")
    except InputError as exc:  # the command's message, about the folder the page loaded
        text = str(exc).replace(f"--log {str(folder)!r}", "the loaded folder").replace(repr(str(folder)), "the loaded folder")
        raise InputError(text, key="resume") from None
    pid = state.remember(service.PlanBundle({"name": f"{spec.name}-resume"}, out, bundle.frame))
    return {"plan_id": pid, "files": sorted(out), "notes": list(start.said), "summary": resumed_text(plan, start),
            "lines": _sortie_routes(plan)}


def _sortie_routes(plan: Plan) -> dict[str, Any]:
    """Each resumed sortie's route as it flies it (its waypoints, WGS84), named by the files it is written to."""
    from aerosurvey import ids

    feats = [{"type": "Feature", "properties": {"role": "route", "id": ids.resume_file_stem(k)},
              "geometry": {"type": "LineString", "coordinates": [[round(w.lon, 8), round(w.lat, 8)] for w in wps]}}
             for k, (_, wps) in enumerate(plan.sorties, start=1)]
    return {"type": "FeatureCollection", "features": feats}
