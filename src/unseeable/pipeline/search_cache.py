"""A disk cache of pose searches, shared by the processes of corpus-wide jobs.

The pose search (:meth:`~unseeable.pipeline.posing.ViewContext.search`: the edge fit and
the choice among the grid's aliases) is most of a single view's estimate, and the
experiments search the same photographs again and again: the several-views experiment
poses its reference view once per number of views and per disassembly pair, active vision
its starting view, the language experiment every image with and without its description,
each after the visibility experiment already did. Inside :func:`pose_searches_cached`
every search is read from, or written to, a folder, keyed by everything it depends on:
the image's pixels, the camera, the extent, the search's settings, the calibration and
the package's own source (any change of the code makes new keys). A search is a
deterministic function of these, and everything after it runs as before, so an estimate
is the same whether its search was read or made (tests/pipeline/test_search_cache.py).

Entries are small (a pose fit: poses and scores, no image data); each is written whole
under a temporary name and then renamed, so processes sharing the folder never read a
half-written one. An entry that cannot be read is searched again and rewritten.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import pickle
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["pose_searches_cached", "cached_search", "search_key", "active_search_cache"]

logger = logging.getLogger(__name__)

_folder: Path | None = None


@contextlib.contextmanager
def pose_searches_cached(folder: str | Path | None) -> Iterator[Path | None]:
    """Read and write pose searches in ``folder`` (created when needed) while inside;
    ``None`` leaves the searches uncached. Nests: the previous folder is restored on exit."""
    global _folder
    previous = _folder
    path = None if folder is None else Path(folder)
    if path is not None:
        path.mkdir(parents=True, exist_ok=True)
    _folder = path
    try:
        yield path
    finally:
        _folder = previous


def active_search_cache() -> Path | None:
    """The folder pose searches are cached in now, or None."""
    return _folder


@functools.cache
def _code_digest() -> str:
    """The package's source and shipped data: a change of either gives new keys."""
    import cv2

    import unseeable

    root = Path(unseeable.__file__).parent
    h = hashlib.sha256(f"{np.__version__} {cv2.__version__}".encode())
    for path in sorted(p for p in root.rglob("*") if p.suffix in (".py", ".json", ".lark")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def _array_bytes(h: Any, a: Any) -> None:
    arr = np.ascontiguousarray(a)
    h.update(f"{arr.dtype.str}{arr.shape}".encode())
    h.update(arr.tobytes())


def search_key(image: np.ndarray, camera: Any, extent: Any, *parts: Any) -> str:
    """The key of a pose search of ``image`` seen by ``camera`` on ``extent``, with
    ``parts`` (settings and the like, by their ``repr``) deciding it too.

    >>> import numpy as np
    >>> from unseeable.camera import Camera
    >>> from unseeable.domain import Extent
    >>> cam = Camera(640, 480, K=[[500, 0, 320], [0, 500, 240], [0, 0, 1]],
    ...              R=np.eye(3), t=[0, 0, 900])
    >>> img = np.zeros((480, 640, 3), np.uint8)
    >>> search_key(img, cam, Extent(2, 2, 2), "a") == search_key(img, cam, Extent(2, 2, 2), "a")
    True
    >>> search_key(img, cam, Extent(2, 2, 2), "a") == search_key(img, cam, Extent(2, 2, 2), "b")
    False
    """
    h = hashlib.sha256(_code_digest().encode())
    _array_bytes(h, image)
    h.update(f"{camera.width}x{camera.height}".encode())
    for a in (camera.K, camera.R, camera.t, camera.dist):
        _array_bytes(h, np.asarray(a, dtype=np.float64))
    h.update(repr(extent).encode())
    for part in parts:
        h.update(b"\0" + repr(part).encode())
    return h.hexdigest()[:32]


def cached_search(key: Callable[[], str], search: Callable[[], Any]) -> Any:
    """``search()``'s result, read from the active cache folder under the key ``key()``
    when there, else made and written there (no folder active: made, and the key, which
    hashes the image, never computed)."""
    folder = _folder
    if folder is None:
        return search()
    key = key()
    path = folder / f"{key}.pickle"
    if path.is_file():
        try:
            with path.open("rb") as f:
                found = pickle.load(f)
            logger.debug("pose search read from %s", path)
            return found
        except Exception as err:  # a damaged entry: searched again below
            logger.warning("cached pose search %s unreadable (%s); searching again", path, err)
    result = search()
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{key}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            pickle.dump(result, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.chmod(tmp, 0o644)  # mkstemp's 0600 would hide it from a cluster's other users
        os.replace(tmp, path)
    except OSError as err:
        logger.warning("could not cache a pose search in %s: %s", folder, err)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
    return result
