"""Commands of the simulated workspace: ``unseeable render`` and ``unseeable cad``."""

from __future__ import annotations

from pathlib import Path

import typer

from unseeable.cli import app
from unseeable.cli.options import flag, parse_angles, parse_pose, parse_size, progress_bar
from unseeable.errors import InputError, check_whole_number

__all__ = ["render_command", "cad_command"]


@app.command("render")
def render_command(
    structure_file: Path = typer.Argument(..., help="Structure file (unseeable/structure@1)."),
    angles: str = typer.Option("90,120,150,180,210", "--angles",
                               help="Arm angles in degrees, comma separated (from +x, "
                                    "counter-clockwise seen from above)."),
    out: Path = typer.Option(..., "--out", metavar="DIR", help="Output folder."),
    pose: str | None = typer.Option(None, "--pose", metavar="X,Z,YAW",
                                    help="Assembly pose X,Z,YAW (mm, mm, deg); default: "
                                         "footprint centred on the table."),
    removed_from_layer: int | None = typer.Option(None, "--removed-from-layer",
                                                  help="Take off every log at layers >= L."),
    size: str = typer.Option("640x480", "--size", help="Image size WIDTHxHEIGHT."),
    spp: int = typer.Option(16, "--spp", help="Samples per pixel."),
    seed: int = typer.Option(0, "--seed", help="Random seed (same seed, same images)."),
    randomise: bool = flag(False, "--randomise",
                           help="Randomise lights, materials, table and camera."),
) -> None:
    """Render photographs of an assembly from the pendulum arm, with their ground truth.

    Writes viewN.png, viewN.json (view), viewN.truth.json (feature presence and
    visibility) and viewN.ids.npz (per-pixel log ids and depth) for N = 1, 2, ...,
    every view or none. An assembly mostly outside a view's image is refused before
    rendering.
    """
    from rich.progress import BarColumn, TextColumn, TimeElapsedColumn

    from unseeable.domain import load_structure
    from unseeable.fileio import check_output_folder, output_folder
    from unseeable.pipeline.files import check_in_image
    from unseeable.render.settings import RenderSettings, SceneRandomisation
    from unseeable.render.view import save_truth, save_view
    from unseeable.render.workspace import PendulumArm, Workspace

    check_output_folder(out)
    angle_list = parse_angles(angles)
    width, height = parse_size(size)
    grid_pose = parse_pose(pose) if pose is not None else None
    structure = load_structure(structure_file)
    settings = RenderSettings(spp=spp,
                              randomisation=SceneRandomisation() if randomise else None)
    if not 0 <= seed < 2**32:
        raise InputError("must be in 0..2**32-1", field="--seed", value=seed)
    if removed_from_layer is not None:  # checked before the progress bar is up
        check_whole_number(removed_from_layer, field="removed_from_layer", minimum=0)
    workspace = Workspace(structure, grid_pose, PendulumArm(width=width, height=height),
                          settings, seed=seed)
    for angle in angle_list:  # before rendering: a view of the table alone is no view
        check_in_image(structure.extent, workspace.pose, workspace.arm.camera(angle),
                       file=None if grid_pose is not None else structure_file,
                       field="--pose" if grid_pose is not None else "extent",
                       what=f"seen from the arm at {angle:g}°, puts")
    written = []
    with output_folder(out) as folder, \
            progress_bar(TextColumn("[bold]rendering[/] {task.description}"), BarColumn(),
                         TextColumn("{task.completed}/{task.total}"),
                         TimeElapsedColumn()) as progress:
        task = progress.add_task("", total=len(angle_list))
        staged = folder.path
        for n, angle in enumerate(angle_list, start=1):
            progress.update(task, description=f"view{n} at {angle:g}°")
            view = workspace.observe(angle, removed_from_layer=removed_from_layer)
            truth = workspace.truth(view)
            save_view(view, staged / f"view{n}.json", image_path=staged / f"view{n}.png")
            save_truth(truth, staged / f"view{n}.truth.json",
                       ids_path=staged / f"view{n}.ids.npz")
            written.append((n, angle, int(truth.present.sum()),
                            int((truth.present & truth.visible).sum())))
            progress.advance(task)
    p = workspace.pose
    typer.echo(f"{len(written)} views of {len(structure.logs)} logs at pose x={p.x:g} "
               f"z={p.z:g} yaw={p.yaw_deg:g} written to {out}")
    for n, angle, present, visible in written:
        typer.echo(f"  view{n}: {angle:g}°, {visible} of {present} present features visible")


@app.command("cad")
def cad_command(
    structure_file: Path | None = typer.Argument(
        None, help="Structure file to mesh (omit and give --notches for one log)."),
    notches: int | None = typer.Option(None, "--notches",
                                       help="Mesh one log of 1, 2 or 3 notches."),
    out: Path = typer.Option(..., "--out", metavar="FILE", help="Mesh file: .stl, .ply or .obj."),
    pose: str | None = typer.Option(None, "--pose", metavar="X,Z,YAW",
                                    help="Place the assembly at X,Z,YAW (default: centred)."),
) -> None:
    """Write the CAD mesh of one log or of a whole assembly (STL, PLY or OBJ by suffix)."""
    from unseeable.domain import load_structure
    from unseeable.fileio import check_output_file
    from unseeable.render.cad import MESH_SUFFIXES, export_mesh, log_mesh, structure_mesh
    from unseeable.render.workspace import default_pose

    if out.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"unknown mesh format; use one of {sorted(MESH_SUFFIXES)}",
                         field="--out", value=str(out))
    if (structure_file is None) == (notches is None):
        raise InputError("give either a structure file or --notches", field="--notches",
                         value=notches)
    check_output_file(out)
    if notches is not None:
        mesh = log_mesh(notches)
        what = f"{notches}-notch log"
    else:
        structure = load_structure(structure_file)
        grid_pose = parse_pose(pose) if pose is not None else default_pose(structure.extent)
        mesh = structure_mesh(structure, grid_pose)
        what = f"assembly of {len(structure.logs)} logs"
    export_mesh(mesh, out)
    lo, hi = mesh.bounds if len(mesh.faces) else ((0, 0, 0), (0, 0, 0))
    size = " x ".join(f"{h - l:.1f}" for l, h in zip(lo, hi))
    typer.echo(f"{what}: {len(mesh.faces)} triangles, {size} mm, written to {out}")
