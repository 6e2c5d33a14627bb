"""The offline basemap's tiles (`aerosurvey serve --basemap FILE`):

  GET    /api/basemap/{z}/{x}/{y}    one tile of the MBTiles or PMTiles file; 404 where it has none. A gzipped
                                     (vector) tile goes as stored with Content-Encoding: gzip, unpacked only
                                     for a client that does not accept gzip
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import Response

from aerosurvey.web.basemap import MAX_TILE, MEDIA, gunzipped, is_gzipped
from aerosurvey.web.state import blocking, not_found, server


async def tile(request: Request) -> Response:
    basemap = server(request).basemap
    if basemap is None:
        return not_found("no basemap file: start the server with --basemap FILE (.mbtiles or .pmtiles)")
    try:
        z, x, y = (int(request.path_params[k]) for k in ("z", "x", "y"))
    except ValueError:
        return not_found("a tile's z, x and y are whole numbers")
    if not (0 <= z <= 30 and 0 <= x < (1 << z) and 0 <= y < (1 << z)):
        return not_found(f"tile {z}/{x}/{y} is outside the tile grid")
    data = await blocking(basemap.tile, z, x, y)
    if data is None:
        return Response(status_code=404)  # outside the file's tiles: the map leaves the place blank
    headers = {"Cache-Control": "max-age=3600"}
    if is_gzipped(data):
        headers["Vary"] = "Accept-Encoding"
        if "gzip" in request.headers.get("accept-encoding", "").lower():
            headers["Content-Encoding"] = "gzip"
        else:
            plain = gunzipped(data)
            if plain is None:
                return not_found(f"tile {z}/{x}/{y} unpacks to more than {MAX_TILE // 1048576} MB or is not valid gzip")
            data = plain
    return Response(data, media_type=MEDIA[basemap.info.format], headers=headers)
