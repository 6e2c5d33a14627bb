"""Every hand-off format from one example: `make handoff-demo` (or `python missions/tools/handoff_example.py OUT`).

1. `aerosurvey plan missions/kubad-abad-fixed-wing.toml --gpkg`: the mission files (.plan with
   rally points, .waypoints), plan.geojson, plan.kml and plan.gpkg;
2. `aerosurvey gcp`: the proposed control points (control_points.geojson/.csv/.gpx);
3. stand-in images: one 8×8 JPEG per camera event of the ArduPlane SITL flight of this
   mission (tests/data/sitl_plane_kubad.bin, 683 events), with EXIF capture times 2.5 s off
   the autopilot's clock, as a camera's would be;
4. `aerosurvey log ingest --plan --images`: events.csv, log_report.json, coverage.tif, geo.txt,
   pix4d_geolocation.csv, metashape_reference.csv;
5. `aerosurvey log gcp-predict`: gcp_predictions.csv;
6. `aerosurvey log gcp-list`: gcp_list.txt, here from the predictions standing in for a marking
   tool's export and the proposed GCPs with the home ground as a stand-in surveyed elevation
   (demo values: a real list needs the marks measured in the images and surveyed GCPs);
7. `aerosurvey plan missions/dji-m3e-block.toml`: a DJI Mavic 3 Enterprise block, whose flights
   are also DJI WPML waylines for DJI Pilot 2 (mission.kmz, sortie-NN.kmz); its .plan files hold
   QGroundControl Survey items (`--qgc survey`, the default).
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "missions" / "kubad-abad-fixed-wing.toml"
DJI_SPEC = ROOT / "missions" / "dji-m3e-block.toml"
LOG = ROOT / "tests" / "data" / "sitl_plane_kubad.bin"
CAMERA_CLOCK_OFFSET_S = -2.5


def run(args: list[str], allowed: tuple[int, ...] = ()) -> None:
    """`aerosurvey ARGS`; an exit code other than 0 stops the demo unless it is `allowed`."""
    from aerosurvey.cli import main

    print("$ aerosurvey " + " ".join(args), flush=True)
    try:  # without click's standalone mode a command's error comes back as its exit code
        code = main(args, standalone_mode=False)
    except SystemExit as exc:
        code = exc.code
    if isinstance(code, int) and code and code not in allowed:
        raise SystemExit(code)


def stand_in_images(folder: Path) -> int:
    from PIL import Image

    from aerosurvey.flight.events import read_events

    ev, _ = read_events(LOG)
    times = ev.utc_s if ev.utc_s is not None else ev.time_s
    folder.mkdir(parents=True, exist_ok=True)
    for k, t in enumerate(times):
        stamp = dt.datetime.fromtimestamp(float(t) + CAMERA_CLOCK_OFFSET_S, dt.UTC)
        exif = Image.Exif()
        sub = exif.get_ifd(0x8769)
        sub[36867] = stamp.strftime("%Y:%m:%d %H:%M:%S")
        sub[37521] = f"{stamp.microsecond // 10000:02d}"
        Image.new("RGB", (8, 8)).save(folder / f"DSC{k + 1:05d}.JPG", exif=exif)
    return len(times)


def stand_in_survey(plan: Path, flight: Path) -> Path:
    """control_points.csv's GCPs with the home ground (events.csv: altitude minus height above home) as elevation."""
    import numpy as np

    from aerosurvey.flight.records import read_events_csv

    ev = read_events_csv(flight / "events.csv")
    ground = float(np.nanmedian(ev.alt_m - ev.rel_alt_m))
    rows = list(csv.DictReader(io.StringIO((plan / "control_points.csv").read_text(encoding="utf-8"))))
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({**r, "elevation": f"{ground:.3f}"})
    path = flight / "surveyed_stand_in.csv"
    path.write_text(out.getvalue(), encoding="utf-8")
    return path


def main(out: Path) -> None:
    plan, flight, images = out / "plan", out / "flight", out / "images"
    run(["plan", str(SPEC), "-o", str(plan), "--gpkg"])
    run(["gcp", str(plan)])
    print(f"{stand_in_images(images)} stand-in images in {images}")
    # the log was flown against an earlier version of this plan (tests/data/README.md): `log ingest`
    # names it another mission and exits 1, with every output written; the hand-off files come from it
    run(["log", "ingest", str(LOG), "--plan", str(plan), "--images", str(images), "-o", str(flight)], allowed=(1,))
    run(["log", "gcp-predict", str(flight), "--plan", str(plan), "-o", str(flight / "gcp_predictions.csv")])
    run(["log", "gcp-list", str(flight / "gcp_predictions.csv"), "--surveyed", str(stand_in_survey(plan, flight)),
         "--images", str(images), "-o", str(flight / "gcp_list.txt")])
    run(["plan", str(DJI_SPEC), "-o", str(out / "dji")])


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "out" / "handoff")
