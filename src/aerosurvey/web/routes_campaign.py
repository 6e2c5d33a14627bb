"""A campaign on the page (`serve --campaign CAMPAIGN`), read-only (web/campaign.py):

  GET    /api/campaign                             register.gpkg's blocks (GeoJSON) by status, with counts
  GET    /api/campaign/blocks/{name}               a block's plan: its summary, its files, its route
  GET    /api/campaign/blocks/{name}/files/{file}  one of its files (attachment)
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import JSONResponse, Response

from aerosurvey.errors import InputError
from aerosurvey.web.campaign import block_file, block_plan, campaign_blocks
from aerosurvey.web.state import attachment, blocking, error, not_found, server

NO_CAMPAIGN = "the server was started without a campaign: aerosurvey serve --campaign CAMPAIGN"


async def campaign(request: Request) -> Response:
    folder = server(request).campaign
    if folder is None:
        return not_found(NO_CAMPAIGN)
    try:
        return JSONResponse(await blocking(campaign_blocks, folder))
    except InputError as exc:
        return error(exc)


async def block(request: Request) -> Response:
    folder = server(request).campaign
    if folder is None:
        return not_found(NO_CAMPAIGN)
    try:
        return JSONResponse(await blocking(block_plan, folder, request.path_params["name"]))
    except InputError as exc:
        return not_found(str(exc))


async def file(request: Request) -> Response:
    folder = server(request).campaign
    if folder is None:
        return not_found(NO_CAMPAIGN)
    name = request.path_params["file"]
    try:
        data = await blocking(block_file, folder, request.path_params["name"], name)
    except InputError as exc:
        return not_found(str(exc))
    return Response(data, media_type="application/octet-stream", headers=attachment(name))
