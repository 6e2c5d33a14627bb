"""What the page's handlers share: the server's state and the JSON request and error helpers.

Handlers are async and run on the event loop: anything that reads or writes files, or
computes for long, goes through `blocking` (a worker thread).
"""

from __future__ import annotations

import io
import itertools
import shutil
import threading
import unicodedata
import zipfile
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ParamSpec, TypeVar
from urllib.parse import quote

from starlette.concurrency import run_in_threadpool
from starlette.datastructures import FormData, UploadFile
from starlette.formparsers import MultiPartException, MultiPartParser
from starlette.requests import Request
from starlette.responses import JSONResponse

from aerosurvey.errors import InputError
from aerosurvey.web import service
from aerosurvey.web.basemap import Basemap
from aerosurvey.web.jobs import JobRunner
from aerosurvey.web.lan import Shares
from aerosurvey.web.vehicle import VehicleLink

P = ParamSpec("P")
T = TypeVar("T")


@dataclass
class ServerState:
    spec_path: Path | None
    spec: dict[str, Any]
    workspace: service.Workspace
    tile_url: str
    runner: JobRunner
    upload_limit: int
    basemap: Basemap | None = None  # the offline basemap file (--basemap), served as tiles
    shares: Shares | None = None  # files shared on the local network (serve --lan), None without it
    campaign: Path | None = None  # the campaign folder shown on the page (serve --campaign), read-only
    vehicle: VehicleLink | None = None  # the vehicle of `serve --connect`, None without it
    plans: OrderedDict[str, service.PlanBundle] = field(default_factory=OrderedDict)
    serial: itertools.count[int] = field(default_factory=lambda: itertools.count(1))
    keep_plans: int = 8  # each holds every file of a plan: a large plan is tens of MB
    _lock: threading.Lock = field(default_factory=threading.Lock)

    def remember(self, bundle: service.PlanBundle) -> str:
        """Keep a finished plan (called from a job's thread) and return its id."""
        with self._lock:
            pid = f"p{next(self.serial)}"
            self.plans[pid] = bundle
            while len(self.plans) > self.keep_plans:
                self.plans.popitem(last=False)
        return pid

    def plan(self, plan_id: str) -> service.PlanBundle | None:
        with self._lock:
            return self.plans.get(plan_id)

    def next_serial(self) -> int:
        with self._lock:
            return next(self.serial)


def server(request: Request) -> ServerState:
    state: ServerState = request.app.state.server
    return state


async def blocking(fn: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
    """Run a blocking call (file I/O, planning, zipping) on a worker thread."""
    return await run_in_threadpool(fn, *args, **kwargs)


def error(exc: Exception, status: int = 400) -> JSONResponse:
    """The API's error body: the message and the spec key at fault (or null)."""
    return JSONResponse({"error": str(exc), "key": getattr(exc, "key", None)}, status_code=status)


def attachment(name: str) -> dict[str, str]:
    """The Content-Disposition header of a download named `name` (RFC 6266): the name itself as UTF-8
    (`filename*`, RFC 5987) and an ASCII fallback for clients that read only `filename` (accents
    dropped, other characters `_`). A header is Latin-1 on the wire: a mission named in Czech would
    not fit it as it is."""
    fallback = "".join(_ascii(c) for c in name)
    return {"Content-Disposition": f"attachment; filename=\"{fallback}\"; filename*=UTF-8''{quote(name, safe='')}"}


def _ascii(c: str) -> str:
    """A character of a file name in ASCII for a quoted header value: its letter without the accent, else `_`."""
    base = unicodedata.normalize("NFKD", c).encode("ascii", "ignore").decode("ascii")
    return base if base.isprintable() and base and base not in ('"', "\\") else "_"


def not_found(message: str) -> JSONResponse:
    return JSONResponse({"error": message, "key": None}, status_code=404)


def plan_gone(request: Request) -> JSONResponse:
    return not_found(f"plan {request.path_params['plan_id']!r} is not kept any more: plan again")


async def spec_body(request: Request) -> dict[str, Any]:
    """The request's {"spec": {...}} JSON body; InputError when it is not one."""
    if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
        raise InputError("request body: send the spec as JSON (Content-Type: application/json)")
    try:
        body = await request.json()
    except ValueError as exc:
        raise InputError(f"request body is not valid JSON: {exc}") from None
    if not isinstance(body, dict) or not isinstance(body.get("spec"), dict):
        raise InputError('request body: expected {"spec": {...}} with the mission spec\'s tables', key="spec")
    spec: dict[str, Any] = body["spec"]
    return spec


async def zones_body(request: Request) -> list[str] | None:
    """The request's drawn exclusion zones, {"zones": [WKT, ...]} beside the spec, or None (the spec's zone files).

    Call after `spec_body` (Starlette keeps the parsed body)."""
    zones = (await request.json()).get("zones")
    if zones is None:
        return None
    if not isinstance(zones, list) or not all(isinstance(z, str) for z in zones):
        raise InputError("zones: expected a list of WKT polygons in longitude/latitude (the zones drawn on the page)",
                         key="zones")
    return zones


async def form_in_memory(request: Request, limit: int, what: str, key: str, max_files: int, max_fields: int) -> FormData:
    """The request's multipart form with its files held in memory, not spooled to a temporary
    file as `request.form()` does above 1 MB; `BodyLimit` bounds the whole body to `limit`.

    The caller closes the form. InputError (naming `what`, for spec key `key`) when the body is
    not a multipart form.
    """
    if request.headers.get("content-type", "").split(";")[0].strip() != "multipart/form-data":
        raise InputError(f"{what}: send the file as the multipart field 'file' (Content-Type: multipart/form-data)", key=key)
    parser = MultiPartParser(request.headers, request.stream(), max_files=max_files, max_fields=max_fields,
                             max_part_size=limit)
    parser.spool_max_size = limit  # Starlette's documented knob: files up to it stay in memory
    try:
        return await parser.parse()
    except MultiPartException as exc:
        raise InputError(f"{what}: {exc.message}", key=key) from None


async def one_file(request: Request, limit: int, what: str, key: str, max_fields: int) -> tuple[str, bytes, FormData]:
    """The multipart form's one file (field `file`) read in memory (`form_in_memory`): its base name, its bytes and the
    form (closed) with its other fields. InputError (naming `what`, for spec key `key`) without one."""
    form = await form_in_memory(request, limit, what, key, max_files=1, max_fields=max_fields)
    upload = form.get("file")
    if not isinstance(upload, UploadFile):
        raise InputError(f"{what}: send the file as the multipart field 'file'", key=key)
    data = await upload.read()  # in memory: the form parser does not spool to disk
    await form.close()
    return Path(upload.filename or "").name, data, form


def save_upload(upload: UploadFile, folder: Path) -> Path:
    """Copy an uploaded file (spooled by the form parser) into `folder` under its own base name.

    Blocking: call through `blocking`.
    """
    folder.mkdir(parents=True, exist_ok=True)
    target = folder / Path(upload.filename or "upload").name
    upload.file.seek(0)
    with open(target, "wb") as fh:
        shutil.copyfileobj(upload.file, fh, 1 << 20)
    return target


def zip_texts(files: Mapping[str, str | bytes]) -> bytes:
    """Files (text or bytes) by name as a zip archive's bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, text in sorted(files.items()):
            zf.writestr(name, text)
    return buf.getvalue()
