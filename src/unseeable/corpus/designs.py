"""The 32 designed structures of the evaluation corpus, as reviewable code.

Like the paper's corpus (32 structures x 5 views), the designs are realistic
Lincoln Log buildings — cabins with doors and windows, plain walls, towers,
L- and U-shapes, structures hiding logs behind walls — grouped in *families*
that share one placement on the table, so that proper-subset relations hold
between them: layer truncations (what the arm leaves after removing every log
from a layer up) and cabins with an inner wall taken out.

The JSON files in ``unseeable/data/corpus/`` are the shipped artefact; this
module generates them. Regenerate after editing a design::

    python -m unseeable.corpus.designs          # rewrite the files
    python -m unseeable.corpus.designs --check  # exit 1 when the files differ

Grid conventions (DESIGN.md §2): layer ``j`` runs along ``i`` when even and
along ``k`` when odd. In :func:`~unseeable.corpus.plan.cabin`, ``front`` is
the wall along ``i`` at the lowest ``k``, ``left`` the wall along ``k`` at the
lowest ``i``.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from unseeable.corpus.designs_index import DATA_DIR, INDEX_FORMAT
from unseeable.corpus.plan import Plan, block, cabin, door, tight, truncate, wall, window
from unseeable.corpus.relations import proper_subsets
from unseeable.domain import Extent, GridPose, LogGeometry, Structure, structure_to_json
from unseeable.fileio import atomic_write_bytes, read_json
from unseeable.grammar.shapes import find_shapes

__all__ = ["Design", "designs", "placed", "index_json", "write_corpus_files",
           "stale_corpus_files", "dump_json", "DATA_DIR", "INDEX_FORMAT"]

logger = logging.getLogger(__name__)



@dataclass(frozen=True)
class Design:
    """One designed structure and its placement on the table."""

    name: str
    structure: Structure
    pose: GridPose
    description: str


def placed(extent: tuple[int, int, int] | Extent, yaw_deg: float,
           offset: tuple[float, float] = (0.0, 0.0),
           geometry: LogGeometry = LogGeometry()) -> GridPose:
    """The pose that puts the footprint's centre at ``offset`` (mm) with yaw ``yaw_deg``.

    Examples
    --------
    >>> p = placed((3, 1, 3), 90.0)
    >>> np.round(p.grid_to_world(np.array([64.0, 0.0, 64.0])), 6).tolist()
    [0.0, 0.0, 0.0]
    """
    ext = extent if isinstance(extent, Extent) else Extent(*extent)
    centre = np.array([(ext.I - 1) * geometry.l1 / 2, 0.0, (ext.K - 1) * geometry.l1 / 2])
    probe = GridPose(0.0, 0.0, yaw_deg)
    x, _, z = np.array([offset[0], 0.0, offset[1]]) - probe.rotation @ centre
    # Rounded so the pose reads well in the index; the footprint stays within 0.05 mm.
    return GridPose(round(float(x), 1) + 0.0, round(float(z), 1) + 0.0, float(yaw_deg))


def designs() -> list[Design]:
    """Build all 32 designs, in the corpus order."""
    out: list[Design] = []

    def add(name: str, structure: Structure, pose: GridPose, description: str) -> None:
        # Extents are tight (no empty far sides), as a user would give them.
        out.append(Design(name, tight(structure), pose, description))

    # -- cabins ------------------------------------------------------------
    # A plain 4x4 cabin, its lower half, and the same cabin with a low hearth
    # inside that its walls hide from the front.
    plan = Plan((4, 6, 4))
    cabin(plan, layers=range(6))
    block(plan, "hearth", i=range(1, 3), k=range(1, 3), layers=range(3), removable=True)
    pose = placed(plan.extent, 20.0, (5.0, -10.0))
    plain = plan.build(without=("hearth",))
    add("cabin-4x4", plain, pose, "4x4 log cabin, 6 layers, no openings")
    add("cabin-4x4-L3", truncate(plain, 3), pose,
        "cabin-4x4 disassembled down to layer 3 (layers 0-2 left)")
    add("cabin-4x4-hearth", plan.build(), pose,
        "cabin-4x4 with a 2x2 hearth inside, 3 layers high, partly hidden by the walls")

    # A cabin with a front door.
    plan = Plan((5, 6, 4))
    cabin(plan, layers=range(6))
    door(plan, "front", at=2, mantel=4)
    pose = placed(plan.extent, -30.0, (-10.0, 5.0))
    full = plan.build()
    add("cabin-door", full, pose, "5x4 cabin, 6 layers, door in the middle of the front wall")
    add("cabin-door-L3", truncate(full, 3), pose,
        "cabin-door disassembled down to layer 3: the door's lower half, no mantel")

    # A front window and a back door the front wall hides.
    plan = Plan((5, 7, 5))
    cabin(plan, layers=range(7))
    window(plan, "front", at=2, sill=2, lintel=6)
    door(plan, "back", at=2, mantel=4)
    pose = placed(plan.extent, 45.0, (0.0, 10.0))
    full = plan.build()
    add("cabin-window", full, pose,
        "5x5 cabin, 7 layers, window in the front wall, door in the back wall")
    add("cabin-window-L5", truncate(full, 5), pose,
        "cabin-window disassembled down to layer 5: window without its mantel, back door whole")

    # The language example: a window left of and perpendicular to a door.
    plan = Plan((5, 7, 5))
    cabin(plan, layers=range(7))
    door(plan, "front", at=2, mantel=4)
    window(plan, "left", at=2, sill=1, lintel=5)
    pose = placed(plan.extent, -75.0, (10.0, 0.0))
    full = plan.build()
    add("cabin-door-window", full, pose,
        "5x5 cabin, 7 layers, front door and a window in the perpendicular left wall")
    add("cabin-door-window-L4", truncate(full, 4), pose,
        "cabin-door-window disassembled down to layer 4: no mantels left")

    # An inner wall along k splits the cabin into two rooms; a side door.
    plan = Plan((5, 6, 5))
    cabin(plan, layers=range(6))
    wall(plan, "partition", along="k", at=2, span=range(5), layers=range(6), removable=True)
    door(plan, "right", at=2, mantel=5)
    pose = placed(plan.extent, 60.0, (-5.0, -5.0))
    full = plan.build()
    add("cabin-partition", full, pose,
        "5x5 cabin, 6 layers, inner wall along k splitting it in two, door in the right wall")
    add("cabin-partition-open", plan.build(without=("partition",)), pose,
        "cabin-partition with its inner wall taken out")
    add("cabin-partition-L3", truncate(full, 3), pose,
        "cabin-partition disassembled down to layer 3")

    # A longer hall: inner wall along i, front door, back window.
    plan = Plan((6, 7, 5))
    cabin(plan, layers=range(7))
    wall(plan, "partition", along="i", at=2, span=range(6), layers=range(7), removable=True)
    door(plan, "front", at=2, mantel=4)
    window(plan, "back", at=3, sill=2, lintel=6)
    pose = placed(plan.extent, -15.0, (0.0, -15.0))
    add("hall", plan.build(), pose,
        "6x5 hall, 7 layers, inner wall along i, front door, back window")
    add("hall-open", plan.build(without=("partition",)), pose,
        "hall with its inner wall taken out")

    # The largest: 6x6, 8 layers, door, two windows, an inner wall.
    plan = Plan((6, 8, 6))
    cabin(plan, layers=range(8))
    wall(plan, "partition", along="i", at=3, span=range(6), layers=range(8), removable=True)
    door(plan, "front", at=2, mantel=4)
    window(plan, "right", at=1, sill=3, lintel=7)
    window(plan, "back", at=3, sill=2, lintel=6)
    pose = placed(plan.extent, 30.0, (10.0, 10.0))
    full = plan.build()
    add("lodge", full, pose,
        "6x6 lodge, 8 layers, inner wall along i, front door, windows in the right and back walls")
    add("lodge-open", plan.build(without=("partition",)), pose,
        "lodge with its inner wall taken out")
    add("lodge-L4", truncate(full, 4), pose,
        "lodge disassembled down to layer 4: door without its mantel")

    # -- plain walls ---------------------------------------------------------
    plan = Plan((5, 5, 1))
    wall(plan, "wall", along="i", at=0, span=range(5), layers=range(5))
    add("wall-5", plan.build(), placed(plan.extent, 10.0, (0.0, 0.0)),
        "straight wall, 5 positions long, 5 layers")

    plan = Plan((5, 7, 1))
    wall(plan, "wall", along="i", at=0, span=range(5), layers=range(7))
    window(plan, "wall", at=2, sill=2, lintel=6)
    add("wall-window", plan.build(), placed(plan.extent, -40.0, (-10.0, 0.0)),
        "straight wall, 5 long, 7 layers, with a window in the middle")

    plan = Plan((4, 6, 1))
    wall(plan, "wall", along="i", at=0, span=range(4), layers=range(6))
    door(plan, "wall", at=2, mantel=4)
    add("wall-door", plan.build(), placed(plan.extent, 75.0, (5.0, 5.0)),
        "straight wall, 4 long, 6 layers, with a door off centre")

    # -- towers --------------------------------------------------------------
    plan = Plan((3, 7, 3))
    cabin(plan, layers=range(7))
    pose = placed(plan.extent, 15.0, (0.0, 5.0))
    full = plan.build()
    add("tower-3", full, pose, "hollow 3x3 tower, 7 layers")
    add("tower-3-L3", truncate(full, 3), pose, "tower-3 disassembled down to layer 3")

    # Walls and a roof deck (a lattice of logs) enclose the tower's core: the
    # cameras see into it only through gaps between logs.
    plan = Plan((3, 6, 3))
    cabin(plan, layers=range(4))
    block(plan, "roof", i=range(3), k=range(3), layers=range(4, 6))
    block(plan, "core", i=range(1, 2), k=range(1, 2), layers=range(4), removable=True)
    pose = placed(plan.extent, -60.0, (-5.0, 0.0))
    add("tower-roofed", plan.build(without=("core",)), pose,
        "hollow 3x3 tower, 4 layers, under a 2-layer roof deck that hides its inside")
    add("tower-roofed-core", plan.build(), pose,
        "tower-roofed with a stack of 1-notch logs in its core, seen only through gaps")

    plan = Plan((4, 5, 3))
    block(plan, "crib", i=range(4), k=range(3), layers=range(5))
    add("crib", plan.build(), placed(plan.extent, 50.0, (0.0, -5.0)),
        "solid 4x3 crib, 5 layers: every grid point occupied, the middle logs hidden")

    plan = Plan((4, 8, 4))
    cabin(plan, layers=range(8))
    window(plan, "front", at=1, sill=2, lintel=6)
    add("tower-window", plan.build(), placed(plan.extent, -20.0, (5.0, 0.0)),
        "hollow 4x4 tower, 8 layers, window in the front wall beside a corner")

    # -- L- and U-shapes ----------------------------------------------------
    plan = Plan((5, 5, 4))
    wall(plan, "front", along="i", at=0, span=range(5), layers=range(5))
    wall(plan, "left", along="k", at=0, span=range(4), layers=range(5))
    add("corner-walls", plan.build(), placed(plan.extent, 35.0, (0.0, 0.0)),
        "two walls meeting at a corner (an L), 5 and 4 long, 5 layers")

    plan = Plan((5, 6, 5))
    wall(plan, "front", along="i", at=0, span=range(5), layers=range(6))
    wall(plan, "right", along="k", at=4, span=range(3), layers=range(6))
    wall(plan, "step", along="i", at=2, span=range(2, 5), layers=range(6))
    wall(plan, "inner", along="k", at=2, span=range(2, 5), layers=range(6))
    wall(plan, "back", along="i", at=4, span=range(3), layers=range(6))
    wall(plan, "left", along="k", at=0, span=range(5), layers=range(6))
    door(plan, "front", at=2, mantel=4)
    pose = placed(plan.extent, -45.0, (-5.0, 10.0))
    full = plan.build()
    add("l-cabin", full, pose, "L-shaped cabin on a 5x5 footprint, 6 layers, front door")
    add("l-cabin-L3", truncate(full, 3), pose, "l-cabin disassembled down to layer 3")

    plan = Plan((5, 5, 4))
    wall(plan, "front", along="i", at=0, span=range(5), layers=range(5))
    wall(plan, "left", along="k", at=0, span=range(4), layers=range(5))
    wall(plan, "right", along="k", at=4, span=range(4), layers=range(5))
    add("u-walls", plan.build(), placed(plan.extent, 80.0, (0.0, 5.0)),
        "three walls (a U) open at the back, 5 layers")

    # -- logs hidden behind a wall -------------------------------------------
    # A tall wall with short returns and, right behind it, a low crib that the
    # wall hides from the front; the side views see it.
    plan = Plan((5, 8, 2))
    wall(plan, "front", along="i", at=0, span=range(5), layers=range(8))
    wall(plan, "left", along="k", at=0, span=range(2), layers=range(8))
    wall(plan, "right", along="k", at=4, span=range(2), layers=range(8))
    block(plan, "crib", i=range(1, 4), k=range(1, 2), layers=range(2), removable=True)
    pose = placed(plan.extent, -10.0, (0.0, 0.0))
    add("screen-wall", plan.build(without=("crib",)), pose,
        "front wall, 5 long, 8 layers, with short returns at both ends")
    add("screen-wall-crib", plan.build(), pose,
        "screen-wall with a low crib right behind it, hidden from the front, seen from the side")
    return out


def index_json(items: list[Design]) -> dict:
    """The corpus index: names, files, descriptions, placements, relations, openings."""
    contains = proper_subsets([d.structure for d in items], [d.pose for d in items])
    subset_of: list[list[int]] = [[] for _ in items]
    for big, smalls in enumerate(contains):
        for small in smalls:
            subset_of[small].append(big)
    entries = []
    for n, d in enumerate(items):
        entries.append({
            "name": d.name,
            "file": f"{d.name}.json",
            "description": d.description,
            "extent": d.structure.extent.as_list(),
            "logs": len(d.structure),
            "pose": d.pose.to_json(),
            "contains": [items[b].name for b in contains[n]],
            "subset_of": [items[b].name for b in subset_of[n]],
            "openings": [p.to_json() for p in find_shapes(d.structure, ("door", "window"))],
        })
    return {"format": INDEX_FORMAT, "designs": entries}


def dump_json(data: object, *, width: int = 96, indent: str = "") -> str:
    """JSON text that keeps every object or list that fits in ``width`` on one line.

    Keeps the shipped files short and reviewable (one log per line).

    Examples
    --------
    >>> print(dump_json({"a": [1, 2], "b": [{"c": 1}]}, width=12))
    {
      "a": [1, 2],
      "b": [{"c": 1}]
    }
    """
    flat = json.dumps(data)
    if len(indent) + len(flat) <= width or not isinstance(data, (dict, list)) or not data:
        return flat
    inner = indent + "  "
    if isinstance(data, dict):
        items = [f"{inner}{json.dumps(k)}: "
                 f"{dump_json(v, width=width, indent=inner).lstrip()}" for k, v in data.items()]
        return "{\n" + ",\n".join(items) + f"\n{indent}}}"
    items = [inner + dump_json(v, width=width, indent=inner).lstrip() for v in data]
    return "[\n" + ",\n".join(items) + f"\n{indent}]"


def _expected_files(items: list[Design]) -> dict[str, object]:
    files: dict[str, object] = {f"{d.name}.json": structure_to_json(d.structure) for d in items}
    files["index.json"] = index_json(items)
    return files


def write_corpus_files(folder: str | Path = DATA_DIR) -> list[Path]:
    """Regenerate the structure JSON files and ``index.json`` in ``folder``.

    Files of designs no longer in :func:`designs` are removed.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    files = _expected_files(designs())
    for old in folder.glob("*.json"):
        if old.name not in files:
            old.unlink()
    written = []
    for name, data in files.items():
        atomic_write_bytes(folder / name, (dump_json(data) + "\n").encode("utf-8"))
        written.append(folder / name)
    logger.info("wrote %d corpus files to %s", len(written), folder)
    return written


def stale_corpus_files(folder: str | Path = DATA_DIR) -> list[str]:
    """Names of files in ``folder`` that differ from what :func:`designs` generates.

    Missing and unexpected files count too; an empty list means up to date.
    """
    folder = Path(folder)
    files = _expected_files(designs())
    stale = [name for name, data in files.items()
             if not (folder / name).is_file() or read_json(folder / name) != data
             or (folder / name).read_text(encoding="utf-8") != dump_json(data) + "\n"]
    stale += sorted(p.name for p in folder.glob("*.json") if p.name not in files)
    return stale


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="only compare the shipped files with the designs")
    parser.add_argument("--out", type=Path, default=DATA_DIR, help="folder of the JSON files")
    args = parser.parse_args(argv)
    if args.check:
        stale = stale_corpus_files(args.out)
        for name in stale:
            sys.stderr.write(f"out of date: {args.out / name}\n")
        return 1 if stale else 0
    written = write_corpus_files(args.out)
    sys.stdout.write(f"wrote {len(written)} files to {args.out}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
