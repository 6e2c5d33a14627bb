"""`aerosurvey serve`: the planner's web page on this machine."""

from __future__ import annotations

import ipaddress
import logging
from pathlib import Path

import click

from aerosurvey.errors import InputError

log = logging.getLogger(__name__)


@click.command()
@click.argument("spec", required=False, type=click.Path(dir_okay=False, path_type=Path))
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on. Anything but a loopback address exposes the page (and your files) to the network.")
@click.option("--port", type=click.IntRange(0, 65535), default=8765, show_default=True, help="TCP port (0: any free port).")
@click.option("--tiles", "tile_url", default="",
              help="XYZ basemap URL template, e.g. https://tile.example.org/{z}/{x}/{y}.png, or a WMTS REST one with "
                   "{TileMatrix}/{TileCol}/{TileRow} (Web Mercator); none by default (no tile server is contacted unless "
                   "set here or on the page).")
@click.option("--basemap", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="A local .mbtiles or .pmtiles file of raster or vector tiles, served by the page itself as its basemap "
                   "(no network).")
@click.option("--max-upload-mb", type=click.IntRange(1, 2048), default=50, show_default=True, help="Largest upload accepted.")
@click.option("--lan", is_flag=True,
              help="Also listen on the local network, where a phone or a DJI remote controller can download the files the "
                   "pilot shares from the page (a QR code per sortie file) and nothing else; the page stays on this machine.")
@click.option("--lan-address", default=None, help="With --lan: this machine's address on the local network (default: the one "
                                                   "its route to a private network leaves from).")
@click.option("--campaign", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="A campaign folder (`aerosurvey campaign plan`): the page shows its blocks on the map coloured by "
                   "status, each opening its plan (read-only).")
@click.option("--connect", "vehicle", default=None,
              help="A vehicle the page checks a mission file against and uploads it to, as `aerosurvey upload` does "
                   "(pymavlink connection string, e.g. tcp:127.0.0.1:5760); nothing is sent but by the pilot's click.")
def serve(spec: Path | None, host: str, port: int, tile_url: str, basemap: Path | None, max_upload_mb: int, lan: bool,
          lan_address: str | None, campaign: Path | None, vehicle: str | None) -> None:
    """Plan, check and download a survey mission in the browser (http://127.0.0.1:8765 by default)."""
    import socket

    import uvicorn  # the web stack loads only for this command

    from aerosurvey.web.app import create_app
    from aerosurvey.web.lan import is_loopback, local_network_address

    if lan_address is not None and not lan:
        raise InputError("--lan-address is given without --lan: add --lan to share files on the local network")
    if lan and not is_loopback(host):
        raise InputError(f"--lan with --host {host}: the page stays on this machine with --lan (leave --host as it is)")
    if lan_address is not None:
        try:
            ipaddress.ip_address(lan_address)
        except ValueError:
            raise InputError(f"--lan-address = {lan_address!r} is not allowed: an IP address of this machine") from None

    if spec is not None and not spec.is_file():
        raise InputError(f"mission spec {str(spec)!r} does not exist")
    if tile_url and not any(all(k in tile_url for k in keys) for keys in (("{z}", "{x}", "{y}"),
                                                                             ("{TileMatrix}", "{TileCol}", "{TileRow}"))):
        raise InputError(f"--tiles = {tile_url!r} is not allowed: an XYZ URL template with {{z}}, {{x}} and {{y}}, or a WMTS "
                         "REST template (Web Mercator) with {TileMatrix}, {TileCol} and {TileRow}")
    listen = "0.0.0.0" if lan else host
    if port == 0:
        with socket.socket() as s:
            s.bind((listen, 0))
            port = s.getsockname()[1]
    shared = f"{lan_address or local_network_address()}:{port}" if lan else None
    if is_loopback(host):
        allowed = [f"127.0.0.1:{port}", f"localhost:{port}", f"[::1]:{port}"]
    else:
        log.warning("listening on %s: anyone who can reach this address can plan with the files in the mission's folder "
                    "and upload files to this machine; the Host check is off (any host name is answered, so a web page "
                    "could reach the server through DNS rebinding), the Origin check stays on (a state-changing request "
                    "from another origin is refused)", host)
        allowed = None
    app = create_app(spec, tile_url=tile_url, allowed_hosts=allowed, upload_limit=max_upload_mb * 1024 * 1024,
                     basemap=basemap, lan=shared, campaign=campaign, vehicle=vehicle)
    shown = "127.0.0.1" if is_loopback(host) else host
    click.echo(f"aerosurvey: open http://{shown}:{port}/ (Ctrl+C to stop)")
    if shared is not None:
        click.echo(f"aerosurvey: files shared from the page are served to the local network at http://{shared}/lan/…; "
                   "nothing else is")
    uvicorn.run(app, host=listen, port=port, log_level="warning")
