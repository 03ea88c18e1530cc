"""unseeable: estimate Lincoln Log assemblies, including the logs a camera cannot see.

Implements and extends Narayanaswamy, Barbu & Siskind, "Seeing Unseeability
to See the Unseeable". The pipeline stages are subpackages: :mod:`.domain`,
:mod:`.grammar`, :mod:`.solve`, :mod:`.camera`, :mod:`.render`, :mod:`.vision`,
:mod:`.visibility`, :mod:`.confidence`, :mod:`.corpus`, :mod:`.evaluate`,
:mod:`.cli`.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

from unseeable.errors import InputError, SolverError, UnseeableError

__version__ = "0.1.0"

__all__ = ["UnseeableError", "InputError", "SolverError", "__version__", "numba_cache_dir"]


def _writable(folder: Path) -> bool:
    return os.access(folder, os.W_OK | os.X_OK)


def _usable(folder: Path, writable: Callable[[Path], bool]) -> bool:
    """``folder`` exists (made now when missing) and can be written to."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return writable(folder)


def numba_cache_dir(package_dir: str | Path, environ: Mapping[str, str], *,
                    writable: Callable[[Path], bool] = _writable) -> Path | None:
    """The folder numba should cache the compiled kernels in, or None to leave numba's own
    choice (beside the sources) alone.

    numba caches a kernel beside its source file, else in the user's cache folder
    (found from ``HOME``); with neither writable — the package installed by root
    and run by another user, ``HOME`` still root's after ``su`` — every kernel
    fails with "cannot cache function ... no locator available". So when the
    package folder cannot be written to, the cache goes to the first usable of
    ``$XDG_CACHE_HOME/unseeable/numba``, the user's own ``~/.cache/unseeable/numba``
    (from the password database as well as ``HOME``) and a per-user folder in
    the temporary folder. A ``NUMBA_CACHE_DIR`` already set is respected.

    Parameters
    ----------
    package_dir : path
        The folder of the installed package.
    environ : mapping
        The environment (``os.environ``).
    writable : callable, optional
        Whether a folder can be written to (``os.access`` by default).

    Returns
    -------
    Path or None
    """
    if environ.get("NUMBA_CACHE_DIR"):
        return None
    package = Path(package_dir)
    pycache = package / "__pycache__"
    if writable(package) and (not pycache.is_dir() or writable(pycache)):
        return None
    homes = []
    if environ.get("XDG_CACHE_HOME"):
        homes.append(Path(environ["XDG_CACHE_HOME"]))
    if environ.get("HOME"):
        homes.append(Path(environ["HOME"]) / ".cache")
    try:
        import pwd

        homes.append(Path(pwd.getpwuid(os.getuid()).pw_dir) / ".cache")
    except (ImportError, KeyError, OSError):
        pass
    candidates = [home / "unseeable" / "numba" for home in homes]
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    candidates.append(Path(tempfile.gettempdir()) / f"unseeable-{uid}" / "numba")
    for folder in candidates:
        if _usable(folder, writable):
            return folder
    return None


def _use_a_writable_numba_cache() -> None:
    """Point numba's cache at a folder this user can write to, before any kernel
    is compiled (:func:`numba_cache_dir`)."""
    folder = numba_cache_dir(Path(__file__).parent, os.environ)
    if folder is None:
        return
    os.environ["NUMBA_CACHE_DIR"] = str(folder)
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: its configuration is read already
        config.CACHE_DIR = str(folder)


_use_a_writable_numba_cache()
