"""`aerosurvey cameras`: list and show the camera database."""

from __future__ import annotations

import click

from aerosurvey.camera import database, get_camera


@click.group(invoke_without_command=True)
@click.pass_context
def cameras(ctx: click.Context) -> None:
    """List the camera database (or `cameras show ID` for one camera)."""
    if ctx.invoked_subcommand is not None:
        return
    db = database()
    width = max(len(c) for c in db)
    click.echo(f"{'id':<{width}}  {'sensor mm':>13}  {'image px':>11}  {'f mm':>5}  {'pitch um':>8}  name")
    for cam in db.values():
        click.echo(
            f"{cam.id:<{width}}  {cam.sensor_width_mm:6.2f}x{cam.sensor_height_mm:<6.2f}  "
            f"{cam.image_width_px:5d}x{cam.image_height_px:<5d}  {cam.focal_mm:5.1f}  {cam.pixel_pitch_um:8.2f}  {cam.name}"
        )


@cameras.command("show")
@click.argument("camera_id")
def show(camera_id: str) -> None:
    """Show one camera with its derived pixel pitch and its source."""
    cam = get_camera(camera_id)
    rows = [
        ("id", cam.id),
        ("name", cam.name),
        ("sensor", f"{cam.sensor_width_mm} x {cam.sensor_height_mm} mm"),
        ("image", f"{cam.image_width_px} x {cam.image_height_px} px"),
        ("focal length", f"{cam.focal_mm} mm"),
        ("pixel pitch", f"{cam.pixel_pitch_um:.3f} um (from width; {cam.pitch_mismatch:.1%} from height)"),
        ("min cycle time", f"{cam.min_cycle_s} s"),
        ("exposure", f"{cam.exposure_s:.6g} s"),
        ("shutter", cam.shutter),
        ("source", cam.source),
    ]
    if cam.notes:
        rows.append(("notes", cam.notes))
    for key, value in rows:
        click.echo(f"{key:>15}: {value}")
