"""`aerosurvey cameras`: list and show the camera database."""

from __future__ import annotations

from collections.abc import Callable

import click

from aerosurvey.camera import Camera, database, get_camera

#: Listing columns: header, cell text, right-aligned? Numbers align right so digits line up.
_COLUMNS: tuple[tuple[str, Callable[[Camera], str], bool], ...] = (
    ("id", lambda c: c.id, False),
    ("sensor mm", lambda c: f"{c.sensor_width_mm:.2f} x {c.sensor_height_mm:5.2f}", True),
    ("image px", lambda c: f"{c.image_width_px} x {c.image_height_px:5d}", True),
    ("f mm", lambda c: f"{c.focal_mm:g}", True),
    ("pitch um", lambda c: f"{c.pixel_pitch_um:.2f}", True),
    ("cycle s", lambda c: f"{c.min_cycle_s:g}", True),
    ("shutter", lambda c: c.shutter, False),
    ("name", lambda c: c.name, False),
)


def format_table(cams: list[Camera]) -> list[str]:
    """The listing as lines, every column as wide as its widest cell so columns align."""
    cells = [[fn(cam) for _, fn, _ in _COLUMNS] for cam in cams]
    headers = [h for h, _, _ in _COLUMNS]
    widths = [max([len(h)] + [len(row[i]) for row in cells]) for i, h in enumerate(headers)]
    lines = []
    for row in [headers, *cells]:
        parts = [
            text.rjust(w) if right else text.ljust(w)
            for text, w, (_, _, right) in zip(row, widths, _COLUMNS)
        ]
        lines.append("  ".join(parts).rstrip())
    return lines


@click.group(invoke_without_command=True)
@click.pass_context
def cameras(ctx: click.Context) -> None:
    """List the camera database (or `cameras show ID` for one camera)."""
    if ctx.invoked_subcommand is not None:
        return
    for line in format_table(list(database().values())):
        click.echo(line)


@cameras.command("show")
@click.argument("camera_id")
def show(camera_id: str) -> None:
    """Show one camera with its derived pixel pitch and its source."""
    cam = get_camera(camera_id)
    rows = [
        ("id", cam.id),
        ("name", cam.name),
        ("sensor", f"{cam.sensor_width_mm:g} x {cam.sensor_height_mm:g} mm"),
        ("image", f"{cam.image_width_px} x {cam.image_height_px} px"),
        ("focal length", f"{cam.focal_mm:g} mm"),
        (
            "pixel pitch",
            f"{cam.pixel_pitch_um:.3f} um from the width ({cam.pixel_pitch_height_um:.3f} um from the height, "
            f"{cam.pitch_mismatch:.1%} apart)",
        ),
        ("min cycle time", f"{cam.min_cycle_s:g} s"),
        ("exposure", f"{cam.exposure_s:.6g} s"),
        ("shutter", cam.shutter),
        ("source", cam.source),
    ]
    if cam.notes:
        rows.append(("notes", cam.notes))
    for key, value in rows:
        click.echo(f"{key:>15}: {value}")
