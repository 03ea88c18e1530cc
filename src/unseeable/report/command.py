"""The ``unseeable view`` command's body: parse nothing, call the library, say what it wrote.

Register it with ``app.command(name="view")(view_command)``.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["view_command"]


def view_command(
    estimate: Path = typer.Argument(..., help="An estimate file (unseeable/estimate@2)."),
    out: Path = typer.Option(None, "--out", help="The page to write (default: beside the "
                             "estimate, with suffix .html)."),
    truth: Path = typer.Option(None, "--truth", help="A structure file, or a view's truth "
                               "file (with the true pose), to colour the logs right or wrong."),
) -> None:
    """Write an interactive 3-D page of an estimate (one HTML file that works offline)."""
    from unseeable.report.viewer import estimate_scene, write_scene_page

    scene = estimate_scene(estimate, truth=truth)
    page = write_scene_page(scene, out if out is not None else estimate.with_suffix(".html"))
    summary = scene["summary"]
    line = f"wrote {page} ({summary.get('logs', 0)} logs"
    if "seen" in summary:
        line += f", {summary['seen']} seen"
    if scene["truth"] is not None:
        line += f"; {scene['truth']['errors']} errors against {scene['truth']['source']}"
    cameras = len(scene["cameras"])
    line += f"; {cameras} camera{'' if cameras == 1 else 's'})"
    typer.echo(line)
    for note in scene["notes"]:
        typer.echo(f"note: {note}")
