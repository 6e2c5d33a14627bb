"""Photogrammetry hand-off files, each read as its own client reads it.

OpenDroneMap is not installable here (a Docker image): its readers are transcribed from its
source (opendm/geo.py GeoFile, opendm/gcp.py GCPFile) into `odm_geo_entries` and
`odm_filtered_gcp`. Pix4D's layout is from its "image geolocation and orientation import
format" page; Metashape's columns from its importReference column codes. The camera
orientation convention is checked against scipy's rotations (independent of capture.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from aerosurvey.errors import InputError
from aerosurvey.flight.handoff import (
    CameraPoses,
    GroundPoint,
    Mark,
    geo_txt,
    metashape_csv,
    odm_gcp_list,
    pix4d_csv,
    predict_marks,
    read_geo_txt,
    read_marks,
)
from aerosurvey.plan import capture
from aerosurvey.reproject import planar

CRS = "EPSG:32633"
OPTICS = capture.Optics(23.4, 15.6, 16.0, 0.0039, 6000, 4000)  # the imaging area is the pixel grid: 6000 x 4000 px of 3.9 µm


def odm_geo_entries(text: str) -> dict[str, tuple]:
    """opendm/geo.py GeoFile: SRS line; per line image x y [z] [3 angles] [2 accuracies] extras."""
    lines = [ln.strip() for ln in text.strip().split("\n")]
    assert lines[0] == "EPSG:4326"
    out = {}
    for line in lines[1:]:
        if line and line[0] != "#":
            parts = line.split()
            assert len(parts) >= 3
            angles = tuple(float(p) for p in parts[4:7]) if len(parts) >= 7 else None
            acc = tuple(float(p) for p in parts[7:9]) if len(parts) >= 9 else None
            out[parts[0]] = (float(parts[1]), float(parts[2]), float(parts[3]), angles, acc)
    return out


def odm_filtered_gcp(text: str, images: set[str], min_images: int = 3) -> list[tuple] | None:
    """opendm/gcp.py GCPFile.read + make_filtered_copy: lines of >= 6 parts, kept when the image
    exists; None (no file) below min_images."""
    lines = [ln.strip() for ln in text.strip().split("\n")]
    kept = []
    for line in lines[1:]:
        if line and line[0] != "#":
            parts = line.split()
            if len(parts) >= 6:
                x, y, z, px, py, fn = parts[:6]
                if fn in images:
                    kept.append((float(x), float(y), float(z), float(px), float(py), fn, " ".join(parts[6:])))
    return kept if len(kept) >= min_images else None


def _poses(n: int = 3, fixed: bool = False) -> CameraPoses:
    rng = np.random.default_rng(1)
    return CameraPoses(tuple(f"DSC{i:05d}.JPG" for i in range(n)), 15.0 + rng.uniform(0, 0.01, n),
                       49.4 + rng.uniform(0, 0.01, n), 400 + rng.uniform(0, 5, n), rng.uniform(0, 360, n),
                       rng.uniform(-5, 5, n) if fixed else np.zeros(n), rng.uniform(-5, 5, n) if fixed else np.zeros(n))


def test_geo_txt_carries_image_names_camera_angles_and_accuracies() -> None:
    p = _poses()
    got = odm_geo_entries(geo_txt(p, 0.05, 0.1))
    assert list(got) == list(p.images)
    for i, name in enumerate(p.images):
        lon, lat, alt, angles, acc = got[name]
        assert abs(lon - p.lon[i]) < 1e-8 and abs(lat - p.lat[i]) < 1e-8 and abs(alt - p.alt_m[i]) < 1e-3
        assert angles == pytest.approx((p.yaw[i], 0.0, 0.0), abs=0.006)
        assert acc == (0.05, 0.1)


def test_pix4d_file_has_a_comment_line_then_nine_columns_latitude_first() -> None:
    p = _poses(fixed=True)
    lines = pix4d_csv(p, 2.0, 4.0).splitlines()
    assert lines[0].startswith("#") and len(lines) == 1 + len(p)
    for i, ln in enumerate(lines[1:]):
        cells = ln.split(",")
        assert len(cells) == 9 and cells[0] == p.images[i]
        lat, lon, alt, yaw, pitch, roll, ah, av = map(float, cells[1:])
        assert -90 <= lat <= 90 and abs(lat - p.lat[i]) < 1e-8 and abs(lon - p.lon[i]) < 1e-8
        assert (yaw, pitch, roll) == pytest.approx((p.yaw[i], p.pitch[i], p.roll[i]), abs=0.006)
        assert (ah, av) == (2.0, 4.0)


def test_metashape_columns_nxyzabcXYZ() -> None:
    p = _poses()
    lines = metashape_csv(p, 2.0, 4.0).splitlines()
    assert lines[0].startswith("#")
    cells = lines[1].split(",")
    assert len(cells) == 10 and cells[0] == p.images[0]
    assert float(cells[1]) == pytest.approx(p.lon[0]) and float(cells[2]) == pytest.approx(p.lat[0])
    assert [float(c) for c in cells[7:]] == [2.0, 2.0, 4.0]


def test_accuracy_must_be_positive() -> None:
    with pytest.raises(InputError, match=r"--accuracy-z = 0.0 is not allowed"):
        geo_txt(_poses(), 1.0, 0.0)


def test_geo_txt_reads_back() -> None:
    p = _poses(fixed=True)
    back = read_geo_txt(geo_txt(p, 1, 2), "geo.txt")
    assert back.images == p.images
    np.testing.assert_allclose(back.pitch, p.pitch, atol=0.006)


angles = st.floats(-25, 25, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 360, allow_nan=False), angles, angles)
def test_camera_fixed_to_the_body_looks_along_the_body_down_axis(yaw: float, pitch: float, roll: float) -> None:
    """A body's down and forward axes (scipy, aircraft 'ZYX' in north-east-down) are the camera's
    optical axis and the image's top, in capture.py's convention."""
    ned = Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).as_matrix()
    to_enu = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1]])
    down, forward = to_enu @ ned[:, 2], to_enu @ ned[:, 0]
    att = capture.Attitudes.of_body(np.array([yaw]), np.array([pitch]), np.array([roll]))
    rays = capture.ray_directions(OPTICS, att, np.array([[0.0, 0.0], [0.0, 1.0]]))[0]
    np.testing.assert_allclose(rays[0], down, atol=1e-9)
    towards_top = rays[1] - rays[0] * np.dot(rays[1], rays[0])
    towards_top /= np.linalg.norm(towards_top)
    np.testing.assert_allclose(towards_top, forward, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.floats(0, 360, allow_nan=False), st.floats(-60, 60), st.floats(-60, 60), st.floats(60, 200))
def test_predicted_pixel_of_a_nadir_photo_over_flat_ground(yaw: float, de: float, dn: float, height: float) -> None:
    """Straight down from `height`: a point de east and dn north of the camera appears
    (de, dn) turned by -yaw, divided by the GSD, from the image centre (row down)."""
    lon0, lat0 = 15.0, 49.4
    x0, y0 = planar(CRS).xy(np.array([lon0]), np.array([lat0]))
    poses = CameraPoses(("A.JPG",), np.array([lon0]), np.array([lat0]), np.array([300.0 + height]), np.array([yaw]),
                        np.zeros(1), np.zeros(1))
    marks = predict_marks(poses, [GroundPoint("G1", float(x0[0]) + de, float(y0[0]) + dn, 300.0)], OPTICS, CRS)
    gsd = height * OPTICS.pixel_mm / OPTICS.focal_mm
    t = math.radians(yaw)
    right, up = de * math.cos(t) - dn * math.sin(t), de * math.sin(t) + dn * math.cos(t)
    col, row = OPTICS.width_px / 2 + right / gsd, OPTICS.height_px / 2 - up / gsd
    inside = 0 <= col <= OPTICS.width_px and 0 <= row <= OPTICS.height_px
    margin = 1.0  # a point on the image's edge may fall either way
    if min(abs(col), abs(col - OPTICS.width_px), abs(row), abs(row - OPTICS.height_px)) < margin:
        return
    assert (len(marks) == 1) == inside
    if inside:
        assert marks[0].image == "A.JPG" and marks[0].gcp == "G1"
        assert marks[0].col == pytest.approx(col, abs=0.1) and marks[0].row == pytest.approx(row, abs=0.1)


def test_odm_keeps_every_line_of_a_list_made_from_marks() -> None:
    marks = [Mark("G1", "DSC00001.JPG", 2000.5, 1500.0), Mark("G1", "DSC00002.JPG", 2100.0, 900.25),
             Mark("G2", "DSC00002.JPG", 50.0, 60.0)]
    surveyed = {"G1": (500100.0, 5470100.0, 301.25), "G2": (500300.0, 5470050.0, 299.5)}
    text = odm_gcp_list(marks, surveyed, CRS, "marks.csv", ["DSC00001.JPG", "DSC00002.JPG", "DSC00003.JPG"])
    assert text.splitlines()[0] == CRS
    kept = odm_filtered_gcp(text, {"DSC00001.JPG", "DSC00002.JPG", "DSC00003.JPG"})
    assert kept is not None and len(kept) == 3
    assert kept[0] == (500100.0, 5470100.0, 301.25, 2000.5, 1500.0, "DSC00001.JPG", "G1")


def test_odm_list_refuses_what_odm_would_drop() -> None:
    surveyed = {"G1": (1.0, 2.0, 3.0)}
    two = [Mark("G1", "A.JPG", 1, 1), Mark("G1", "B.JPG", 1, 1)]
    with pytest.raises(InputError, match="2 image mark"):
        odm_gcp_list(two, surveyed, CRS, "m.csv")
    with pytest.raises(InputError, match=r"image\(s\) C.JPG are not in the images folder"):
        odm_gcp_list([*two, Mark("G1", "C.JPG", 1, 1)], surveyed, CRS, "m.csv", ["A.JPG", "B.JPG"])
    with pytest.raises(InputError, match=r"GCP\(s\) G9 have marks but no surveyed coordinates"):
        odm_gcp_list([*two, Mark("G9", "A.JPG", 1, 1)], surveyed, CRS, "m.csv")


def test_marks_csv_with_or_without_header() -> None:
    a = read_marks("gcp,image,x,y\nG1,A.JPG,10,20.5\n", "m.csv")
    b = read_marks("G1,A.JPG,10,20.5\n", "m.csv")
    assert a == b == [Mark("G1", "A.JPG", 10.0, 20.5)]
    with pytest.raises(InputError, match=r"m.csv row 1: pixel x '-3'"):
        read_marks("G1,A.JPG,-3,4\n", "m.csv")


def test_predict_then_list_on_the_command_line(tmp_path: Path) -> None:
    """The example's plan and control points, a geo.txt of photos straight over two GCPs: the
    predictions name those images, and a marks file made from them gives a list ODM keeps."""
    from click.testing import CliRunner

    from aerosurvey.cli import main

    root = Path(__file__).resolve().parents[2]
    plan_dir = tmp_path / "plan"
    r = CliRunner().invoke(main, ["plan", str(root / "missions" / "obratan-72ha.toml"), "-o", str(plan_dir)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["gcp", str(plan_dir)])
    assert r.exit_code == 0, r.output
    import json

    feats = json.loads((plan_dir / "control_points.geojson").read_text())["features"]
    gcps = [f for f in feats if f["properties"]["role"] == "gcp"][:2]
    flight = tmp_path / "flight"
    flight.mkdir()
    lines = ["EPSG:4326"]
    for k, f in enumerate(gcps):
        lon, lat = f["geometry"]["coordinates"]
        for j, dlat in enumerate((-0.0002, 0.0, 0.0002)):
            lines.append(f"IMG_{k}{j}.JPG {lon:.8f} {lat + dlat:.8f} 400.000 90.00 0.00 0.00 2 4")
    (flight / "geo.txt").write_text("\n".join(lines) + "\n")
    (flight / "events.csv").write_text("# aerosurvey-events 2\nevent,time_s,lat,lon,alt_m,rel_alt_m,roll,pitch,yaw,mode,"
                                       "station,distance_m,ground_m,agl_m\n1,0,49.4,15,400,100,0,0,90,,,,,\n")
    out = tmp_path / "pred.csv"
    r = CliRunner().invoke(main, ["log", "gcp-predict", str(flight), "--plan", str(plan_dir), "-o", str(out)])
    assert r.exit_code == 0, r.output
    rows = [ln.split(",") for ln in out.read_text().splitlines()[1:]]
    assert {(g, i[:5]) for g, i, *_ in rows} == {(f["properties"]["id"], f"IMG_{k}") for k, f in enumerate(gcps)}
    # the photo straight over each GCP sees it at the image centre
    centre = {(g, i): (float(c), float(w)) for g, i, c, w in rows}
    for k, f in enumerate(gcps):
        c, w = centre[(f["properties"]["id"], f"IMG_{k}1.JPG")]
        assert abs(c - 3000) < 30 and abs(w - 2000) < 30  # the example's camera: 6000 x 4000 px
    surveyed = tmp_path / "surveyed.csv"
    surveyed.write_text("id,easting,northing,elevation,crs\n" + "".join(
        f"{f['properties']['id']},{f['properties']['easting']},{f['properties']['northing']},300.0,{f['properties']['crs']}\n"
        for f in gcps))
    gl = tmp_path / "gcp_list.txt"
    r = CliRunner().invoke(main, ["log", "gcp-list", str(out), "--surveyed", str(surveyed), "-o", str(gl)])
    assert r.exit_code == 0, r.output
    kept = odm_filtered_gcp(gl.read_text(), {f"IMG_{k}{j}.JPG" for k in range(2) for j in range(3)})
    assert kept is not None and len(kept) == len(rows)


def test_control_points_csv_opens_as_points_in_gdal(tmp_path: Path) -> None:
    """control_points.csv with its .prj: GDAL's CSV driver gives point geometry in WGS84 at lon/lat."""
    import pyogrio
    import shapely
    from click.testing import CliRunner

    from aerosurvey.cli import main

    root = Path(__file__).resolve().parents[2]
    plan_dir = tmp_path / "plan"
    assert CliRunner().invoke(main, ["plan", str(root / "missions" / "obratan-72ha.toml"), "-o", str(plan_dir)]).exit_code == 0
    assert CliRunner().invoke(main, ["gcp", str(plan_dir)]).exit_code == 0
    path = plan_dir / "control_points.csv"
    assert pyogrio.read_info(path)["crs"] is not None
    _, _, geoms, fields = pyogrio.raw.read(path, columns=["lat", "lon"])
    assert len(geoms) > 0
    for g, lat, lon in zip(geoms, *fields):
        p = shapely.from_wkb(g)
        assert p.geom_type == "Point" and abs(p.x - float(lon)) < 1e-8 and abs(p.y - float(lat)) < 1e-8
