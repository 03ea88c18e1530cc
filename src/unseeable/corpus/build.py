"""Render the corpus (5 views of each designed structure) and read it back.

Layout of a corpus folder ``DIR``::

    DIR/corpus.json                      manifest (unseeable/corpus@1)
    DIR/<name>/structure.json            the design (unseeable/structure@1)
    DIR/<name>/view<angle>.png           photograph from the arm at <angle> degrees
    DIR/<name>/view<angle>.json          view (unseeable/view@1): image, camera, extent, pose
    DIR/<name>/view<angle>.truth.json    ground truth (unseeable/truth@1)
    DIR/<name>/view<angle>.ids.npz       per-pixel log ids and depth
    DIR/<name>/view<angle>.stamp.json    settings hash, written after the four files above

Views are written with the same functions as ``unseeable render``
(:func:`unseeable.render.view.save_view`, :func:`~unseeable.render.view.save_truth`),
each file atomically. A view is *complete* when its stamp holds the hash of
everything that determines it (structure, pose, angle, image size, arm,
render settings, seeds) and its four files exist; complete views are skipped,
so an interrupted build resumes where it stopped and a build with other
settings re-renders only what changed. The manifest lists every design whose
requested views are all complete.

Seeds: each structure has one scene seed (its look: table, lights, wood, the
same in all its views) and each view one render seed (noise, camera jitter),
both derived from ``seed`` and the design's name (and the angle), so a view's
pixels do not depend on which other views are built, or in which order.

Manifest (``unseeable/corpus@1``)::

    {"format": "unseeable/corpus@1",
     "render": {"angles": [...], "width": W, "height": H, "spp": N, "seed": S,
                "randomise": false, "settings": {...}, "arm": {...}},
     "entries": [{"name": .., "description": .., "structure": "<name>/structure.json",
                  "extent": [I, J, K], "pose": {"x", "z", "yaw_deg"},
                  "subset_of": [..], "contains": [..],
                  "views": [{"angle": 90.0, "view": "<name>/view90.json",
                             "image": "<name>/view90.png", "truth": "<name>/view90.truth.json",
                             "ids": "<name>/view90.ids.npz", "settings_hash": ".."}]}]}
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from unseeable.camera.io import camera_to_json
from unseeable.corpus.designs_index import CorpusEntry, list_designs, load_design, pose_from_json
from unseeable.domain import GridPose, Structure, load_structure, structure_to_json
from unseeable.errors import InputError
from unseeable.executor import Executor, executor_or_processes
from unseeable.fileio import check_format, read_json, require, write_json
from unseeable.render.settings import recorded_fields

if TYPE_CHECKING:  # the render stage is imported where it is used
    from unseeable.render.view import View, ViewTruth

__all__ = [
    "CORPUS_FORMAT",
    "DEFAULT_ANGLES",
    "ViewJob",
    "ViewDone",
    "BuildReport",
    "build_corpus",
    "plan_views",
    "render_view_job",
    "Corpus",
    "CorpusItem",
    "CorpusView",
    "load_corpus",
    "view_stem",
    "write_manifest",
]

logger = logging.getLogger(__name__)

CORPUS_FORMAT = "unseeable/corpus@1"
STAMP_FORMAT = "unseeable/corpus-stamp@1"
#: The paper's five stations of the pendulum arm (degrees).
DEFAULT_ANGLES = (90.0, 120.0, 150.0, 180.0, 210.0)
MANIFEST = "corpus.json"
#: Suffixes of the files of one view, after ``view<angle>``.
VIEW_SUFFIXES = {"image": ".png", "view": ".json", "truth": ".truth.json", "ids": ".ids.npz"}


def view_stem(angle: float) -> str:
    """File stem of the view at ``angle`` degrees: ``view90``, ``view22.5``, ``view-30``."""
    return f"view{float(angle):g}"


def _derived_seed(*parts: object) -> int:
    """A 32-bit seed from text parts (stable across processes and Python versions)."""
    digest = hashlib.sha256(":".join(map(str, parts)).encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "little")


def _canonical(value: Any) -> Any:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        # A field added after corpora were built counts only when set: theirs stay complete.
        return {f.name: _canonical(getattr(value, f.name)) for f in recorded_fields(value)}
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


@dataclass(frozen=True)
class ViewJob:
    """Everything that determines one rendered view of the corpus.

    Attributes
    ----------
    name : str
        The design.
    structure : Structure
    pose : GridPose
    angle : float
        Station of the pendulum arm (degrees).
    folder : Path
        ``DIR/<name>``.
    arm : PendulumArm
    settings : RenderSettings
    scene_seed, render_seed : int
        The structure's look and this view's noise and camera jitter.
    """

    name: str
    structure: Structure
    pose: GridPose
    angle: float
    folder: Path
    arm: Any
    settings: Any
    scene_seed: int
    render_seed: int

    @property
    def stem(self) -> str:
        return view_stem(self.angle)

    def path(self, what: str) -> Path:
        """Path of the view's ``image``, ``view``, ``truth``, ``ids`` or ``stamp`` file."""
        suffix = ".stamp.json" if what == "stamp" else VIEW_SUFFIXES[what]
        return self.folder / f"{self.stem}{suffix}"

    @property
    def settings_hash(self) -> str:
        """SHA-256 of everything that determines this view's files."""
        key = {
            "format": CORPUS_FORMAT,
            "structure": structure_to_json(self.structure),
            "pose": self.pose.to_json(),
            "angle": float(self.angle),
            # the camera, not the whole arm: its list of stations does not matter here
            "camera": _canonical(camera_to_json(self.arm.camera(self.angle))),
            "settings": _canonical(self.settings),
            "scene_seed": self.scene_seed,
            "render_seed": self.render_seed,
        }
        text = json.dumps(key, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def is_complete(self) -> bool:
        """Whether the view's files exist and its stamp matches :attr:`settings_hash`."""
        stamp = self.path("stamp")
        if not stamp.is_file() or not all(self.path(w).is_file() for w in VIEW_SUFFIXES):
            return False
        try:
            data = json.loads(stamp.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return False
        return isinstance(data, dict) and data.get("settings_hash") == self.settings_hash


@dataclass(frozen=True)
class ViewDone:
    """Outcome of one view job."""

    name: str
    angle: float
    rendered: bool
    seconds: float
    present: int = 0
    visible: int = 0


def render_view_job(job: ViewJob) -> ViewDone:
    """Render one view of the corpus and write its files (runs in a worker process).

    The stamp is removed first and written last, so a view interrupted half
    way is never taken for complete.
    """
    from unseeable.render.view import save_truth, save_view
    from unseeable.render.workspace import Workspace

    start = time.perf_counter()
    job.path("stamp").unlink(missing_ok=True)
    workspace = Workspace(job.structure, job.pose, job.arm, job.settings, seed=job.render_seed)
    # One look per structure (same table and lights in all its views); the
    # workspace's own seed then only drives this view's noise and jitter.
    workspace.look = job.settings.scene_for(job.scene_seed)
    view = workspace.observe(job.angle)
    truth = workspace.truth(view)
    save_view(view, job.path("view"), image_path=job.path("image"))
    save_truth(truth, job.path("truth"), ids_path=job.path("ids"))
    write_json(job.path("stamp"), {"format": STAMP_FORMAT, "settings_hash": job.settings_hash,
                                   "angle": float(job.angle), "render_seed": job.render_seed,
                                   "scene_seed": job.scene_seed})
    return ViewDone(job.name, job.angle, True, time.perf_counter() - start,
                    int(truth.present.sum()), int((truth.present & truth.visible).sum()))


def _angles(angles: Sequence[float]) -> tuple[float, ...]:
    out = []
    for a in angles:
        if isinstance(a, bool) or not isinstance(a, (int, float, np.integer, np.floating)) \
                or not np.isfinite(a):
            raise InputError("must be finite angles in degrees", field="angles", value=a)
        out.append(float(a))
    if not out:
        raise InputError("must name at least one angle", field="angles", value=list(angles))
    if len({view_stem(a) for a in out}) != len(out):
        raise InputError("names the same angle twice", field="angles", value=out)
    return tuple(out)


def _select(only: Sequence[str] | None) -> list[CorpusEntry]:
    if not only:
        return list_designs()
    entries = []
    for name in dict.fromkeys(only):
        try:
            entries.append(load_design(name))
        except InputError as err:
            raise InputError(err.message, field="only", value=name) from None
    return entries


def plan_views(out: str | Path, *, angles: Sequence[float] = DEFAULT_ANGLES,
               size: tuple[int, int] = (640, 480), settings: Any = None, seed: int = 0,
               only: Sequence[str] | None = None, randomise: bool = False) -> list[ViewJob]:
    """The view jobs of a corpus build, in corpus order (nothing is rendered).

    Parameters are those of :func:`build_corpus`.
    """
    from unseeable.render.settings import RenderSettings, SceneRandomisation
    from unseeable.render.workspace import PendulumArm

    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) \
            or not 0 <= seed < 2**32:
        raise InputError("must be in 0..2**32-1", field="seed", value=seed)
    angle_list = _angles(angles)
    width, height = size
    if settings is None:
        settings = RenderSettings()
    if randomise and settings.randomisation is None:
        settings = settings.with_(randomisation=SceneRandomisation())
    arm = PendulumArm(width=width, height=height)
    root = Path(out)
    jobs = []
    for entry in _select(only):
        scene_seed = _derived_seed(seed, entry.name)
        for angle in angle_list:
            jobs.append(ViewJob(entry.name, entry.structure, entry.pose, angle,
                                root / entry.name, arm, settings, scene_seed,
                                _derived_seed(seed, entry.name, view_stem(angle))))
    return jobs


@dataclass(frozen=True)
class BuildReport:
    """What a corpus build did."""

    root: Path
    rendered: tuple[ViewDone, ...]
    skipped: tuple[ViewJob, ...]
    manifest: Path
    entries: int
    seconds: float

    @property
    def total(self) -> int:
        return len(self.rendered) + len(self.skipped)


def build_corpus(out: str | Path, *, angles: Sequence[float] = DEFAULT_ANGLES,
                 size: tuple[int, int] = (640, 480), settings: Any = None, seed: int = 0,
                 only: Sequence[str] | None = None, workers: int = 1, randomise: bool = False,
                 executor: Executor | None = None,
                 progress: Callable[[ViewJob | ViewDone, bool], None] | None = None,
                 ) -> BuildReport:
    """Render the views of the corpus designs into ``out`` (cached, resumable).

    Parameters
    ----------
    out : path
        The corpus folder (created when missing).
    angles : sequence of float
        Stations of the pendulum arm, degrees (default: the paper's five).
    size : (int, int)
        Image width and height in pixels.
    settings : RenderSettings, optional
        Render settings (samples per pixel, ...); default ``RenderSettings()``.
    seed : int
        Root of every seed (see the module's notes).
    only : sequence of str, optional
        Build only these designs (the manifest still lists every complete one).
    workers : int
        Processes rendering in parallel (1: in this process), when no ``executor``
        is given.
    randomise : bool
        Draw each structure's look (lights, wood, table) and each view's
        camera jitter from the default :class:`SceneRandomisation`.
    executor : Executor, optional
        Renders the views (:mod:`unseeable.executor`: local processes or a Dask
        cluster); default ``workers`` local processes. The images do not depend on it.
    progress : callable, optional
        Called with ``(job, False)`` for each skipped view and
        ``(done, True)`` for each rendered one, as they finish.

    Returns
    -------
    BuildReport

    Raises
    ------
    InputError
        For unknown design names or unusable options.
    RenderError
        When the renderer fails (views finished so far stay cached).
    """
    start = time.perf_counter()
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= 256:
        raise InputError("must be a whole number in 1..256", field="workers", value=workers)
    root = Path(out)
    jobs = plan_views(root, angles=angles, size=size, settings=settings, seed=seed, only=only,
                      randomise=randomise)
    settings = jobs[0].settings
    arm = jobs[0].arm
    for job in jobs:
        job.folder.mkdir(parents=True, exist_ok=True)
    todo, skipped = [], []
    for job in jobs:
        (skipped if job.is_complete() else todo).append(job)
    for job in skipped:
        if progress is not None:
            progress(job, False)
    logger.info("corpus build: %d views to render, %d cached", len(todo), len(skipped))
    rendered = []
    executor = executor_or_processes(executor, workers)
    for done in executor.map_unordered(render_view_job, todo):
        rendered.append(done)
        if progress is not None:
            progress(done, True)
    manifest, count = write_manifest(root, angles=_angles(angles), size=size,
                                     settings=settings, arm=arm, seed=seed, randomise=randomise)
    return BuildReport(root, tuple(rendered), tuple(skipped), manifest, count,
                       time.perf_counter() - start)


def write_manifest(root: str | Path, *, angles: Sequence[float], size: tuple[int, int],
                   settings: Any, arm: Any, seed: int, randomise: bool) -> tuple[Path, int]:
    """Write ``root/corpus.json`` listing every design whose views are all complete.

    Returns
    -------
    path : Path
    entries : int
        How many designs it lists.
    """
    root = Path(root)
    jobs = plan_views(root, angles=angles, size=size, settings=settings, seed=seed,
                      randomise=randomise)
    by_name: dict[str, list[ViewJob]] = {}
    for job in jobs:
        by_name.setdefault(job.name, []).append(job)
    complete = {name for name, js in by_name.items() if all(j.is_complete() for j in js)}
    entries = []
    for entry in list_designs():
        if entry.name not in complete:
            continue
        structure_file = root / entry.name / "structure.json"
        data = structure_to_json(entry.structure)
        if not structure_file.is_file() or read_json(structure_file) != data:
            write_json(structure_file, data)
        entries.append({
            "name": entry.name,
            "description": entry.description,
            "structure": f"{entry.name}/structure.json",
            "extent": entry.structure.extent.as_list(),
            "pose": entry.pose.to_json(),
            "subset_of": [n for n in entry.subset_of if n in complete],
            "contains": [n for n in entry.contains if n in complete],
            "views": [{
                "angle": job.angle,
                **{what: f"{entry.name}/{job.path(what).name}" for what in VIEW_SUFFIXES},
                "settings_hash": job.settings_hash,
            } for job in by_name[entry.name]],
        })
    manifest = {
        "format": CORPUS_FORMAT,
        "render": {
            "angles": [float(a) for a in angles],
            "width": int(size[0]),
            "height": int(size[1]),
            "spp": int(settings.spp),
            "seed": int(seed),
            "randomise": bool(randomise),
            "settings": _canonical(settings),
            "arm": _canonical(arm),
        },
        "entries": entries,
    }
    path = root / MANIFEST
    write_json(path, manifest)
    return path, len(entries)


# --------------------------------------------------------------------------
# reading a corpus back


@dataclass(frozen=True)
class CorpusView:
    """The files of one view of a corpus structure."""

    angle: float
    view: Path
    image: Path
    truth: Path
    ids: Path
    settings_hash: str

    def load_view(self) -> View:
        """The :class:`~unseeable.render.view.View` (image loaded on use)."""
        from unseeable.render.view import load_view

        return load_view(self.view)

    def load_truth(self) -> ViewTruth:
        """The :class:`~unseeable.render.view.ViewTruth` with its id and depth maps."""
        from unseeable.render.view import load_truth

        return load_truth(self.truth)


@dataclass(frozen=True)
class CorpusItem:
    """One structure of a rendered corpus with its views."""

    name: str
    description: str
    structure: Structure
    structure_file: Path
    pose: GridPose
    subset_of: tuple[str, ...]
    contains: tuple[str, ...]
    views: tuple[CorpusView, ...]

    @property
    def angles(self) -> tuple[float, ...]:
        return tuple(v.angle for v in self.views)

    def view(self, angle: float) -> CorpusView:
        """The view at ``angle`` degrees."""
        for v in self.views:
            if view_stem(v.angle) == view_stem(angle):
                return v
        raise InputError(f"{self.name} has no view at this angle (it has "
                         f"{', '.join(f'{a:g}' for a in self.angles)})", field="angle",
                         value=angle)


@dataclass(frozen=True)
class Corpus:
    """A rendered corpus: its structures, their views and how it was rendered."""

    root: Path
    items: tuple[CorpusItem, ...]
    render: dict

    @property
    def names(self) -> list[str]:
        return [item.name for item in self.items]

    @property
    def angles(self) -> tuple[float, ...]:
        return tuple(float(a) for a in self.render["angles"])

    def __len__(self) -> int:
        return len(self.items)

    def __iter__(self) -> Iterator[CorpusItem]:
        return iter(self.items)

    def __getitem__(self, name: str) -> CorpusItem:
        for item in self.items:
            if item.name == name:
                return item
        raise InputError("no such structure in the corpus", file=self.root / MANIFEST,
                         field="name", value=name)

    def pairs(self) -> list[tuple[str, str]]:
        """``(smaller, larger)`` names of every proper-subset pair in the corpus."""
        return [(item.name, big) for item in self.items for big in item.subset_of]


def _relative_file(root: Path, value: Any, *, file: Path, field: str) -> Path:
    if not isinstance(value, str) or not value or Path(value).is_absolute() \
            or ".." in Path(value).parts:
        raise InputError("must be a path relative to the corpus folder", file=file, field=field,
                         value=value)
    path = root / value
    if not path.is_file():
        raise InputError("names a missing file", file=file, field=field, value=value)
    return path


def _names(value: Any, *, file: Path, field: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError("must be a list of structure names", file=file, field=field,
                         value=value)
    return tuple(value)


def load_corpus(root: str | Path) -> Corpus:
    """Read and validate a rendered corpus folder (its ``corpus.json``).

    Checks the format tag, the render block, every entry's structure file
    (grammar included), pose, view files (present on disk, angles matching the
    render block) and that subset relations name structures of the corpus.

    Raises
    ------
    InputError
        Naming the manifest, the field (e.g. ``entries[3].views[1].image``)
        and the value at fault.
    """
    root = Path(root)
    path = root / MANIFEST
    if root.is_dir() and not path.is_file():
        raise InputError(f"is not a corpus folder (no {MANIFEST}; build one with "
                         "`unseeable corpus build`)", file=root)
    data = read_json(path)
    check_format(data, CORPUS_FORMAT, file=path)
    render = require(data, "render", file=path)
    if not isinstance(render, dict):
        raise InputError("must be an object", file=path, field="render", value=render)
    raw_angles = require(render, "angles", file=path, prefix="render.")
    try:
        angles = _angles(raw_angles if isinstance(raw_angles, list) else [None])
    except InputError as err:
        raise InputError(err.message, file=path, field="render.angles", value=raw_angles) \
            from None
    for key in ("width", "height", "spp", "seed"):
        v = require(render, key, file=path, prefix="render.")
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise InputError("must be a whole number", file=path, field=f"render.{key}", value=v)
    entries = require(data, "entries", file=path)
    if not isinstance(entries, list):
        raise InputError("must be a list", file=path, field="entries", value=type(entries).__name__)
    items = []
    for n, e in enumerate(entries):
        where = f"entries[{n}]"
        if not isinstance(e, dict):
            raise InputError("must be an object", file=path, field=where, value=e)
        name = require(e, "name", file=path, prefix=f"{where}.")
        if not isinstance(name, str) or not name:
            raise InputError("must be a non-empty string", file=path, field=f"{where}.name",
                             value=name)
        structure_file = _relative_file(root, require(e, "structure", file=path,
                                                      prefix=f"{where}."),
                                        file=path, field=f"{where}.structure")
        structure = load_structure(structure_file)
        extent = e.get("extent")
        if extent is not None and extent != structure.extent.as_list():
            raise InputError(f"differs from the structure file's {structure.extent.as_list()}",
                             file=path, field=f"{where}.extent", value=extent)
        pose = pose_from_json(require(e, "pose", file=path, prefix=f"{where}."), file=path,
                              field=f"{where}.pose")
        raw_views = require(e, "views", file=path, prefix=f"{where}.")
        if not isinstance(raw_views, list):
            raise InputError("must be a list", file=path, field=f"{where}.views",
                             value=raw_views)
        views = []
        for m, v in enumerate(raw_views):
            vw = f"{where}.views[{m}]"
            if not isinstance(v, dict):
                raise InputError("must be an object", file=path, field=vw, value=v)
            angle = require(v, "angle", file=path, prefix=f"{vw}.")
            if isinstance(angle, bool) or not isinstance(angle, (int, float)) \
                    or view_stem(angle) not in {view_stem(a) for a in angles}:
                raise InputError("must be one of the render block's angles "
                                 f"{[float(a) for a in angles]}", file=path,
                                 field=f"{vw}.angle", value=angle)
            files = {what: _relative_file(root, require(v, what, file=path, prefix=f"{vw}."),
                                          file=path, field=f"{vw}.{what}")
                     for what in VIEW_SUFFIXES}
            digest = v.get("settings_hash", "")
            if not isinstance(digest, str):
                raise InputError("must be a string", file=path, field=f"{vw}.settings_hash",
                                 value=digest)
            views.append(CorpusView(float(angle), files["view"], files["image"],
                                    files["truth"], files["ids"], digest))
        if len({view_stem(v.angle) for v in views}) != len(views):
            raise InputError("lists the same angle twice", file=path, field=f"{where}.views",
                             value=[v.angle for v in views])
        description = e.get("description", "")
        if not isinstance(description, str):
            raise InputError("must be a string", file=path, field=f"{where}.description",
                             value=description)
        items.append(CorpusItem(
            name, description, structure, structure_file, pose,
            _names(e.get("subset_of", []), file=path, field=f"{where}.subset_of"),
            _names(e.get("contains", []), file=path, field=f"{where}.contains"),
            tuple(views)))
    names = [item.name for item in items]
    for n, item in enumerate(items):
        if names.index(item.name) != n:
            raise InputError("lists the same structure twice", file=path,
                             field=f"entries[{n}].name", value=item.name)
        for key in ("subset_of", "contains"):
            for other in getattr(item, key):
                if other not in names:
                    raise InputError("names no structure of the corpus", file=path,
                                     field=f"entries[{n}].{key}", value=other)
    return Corpus(root, tuple(items), render)
