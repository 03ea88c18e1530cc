"""Evidence: a prior p_f that each feature is present (DESIGN.md §2, §6).

An absent (unjudged or occluded) feature has p_f = ½ and does not change
which structure is most probable. The log-probability of a structure under
evidence is ``Σ_f log p_f(g_f(Z))`` over all features of the extent, with
``p_f(True) = p_f`` and ``p_f(False) = 1 - p_f``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.domain.grid import Extent
from unseeable.domain.structure import Structure
from unseeable.errors import InputError
from unseeable.fileio import check_format, read_json, require, write_json

__all__ = ["Evidence", "EVIDENCE_FORMAT", "load_evidence", "save_evidence",
           "evidence_from_json", "evidence_to_json", "simulate_evidence", "P_MIN"]

EVIDENCE_FORMAT = "unseeable/evidence@1"
#: Priors are clipped to [P_MIN, 1 - P_MIN] so no feature is infinitely sure.
P_MIN = 1e-4


@dataclass(frozen=True, eq=False)
class Evidence:
    """Priors for every feature of an extent, in :func:`feature_index` order.

    Parameters
    ----------
    extent : Extent
    p : (N,) float
        Prior that each feature is present, in (0, 1); ½ = no evidence.

    Examples
    --------
    >>> e = Evidence.uniform(Extent(2, 1, 1))
    >>> float(e.p.mean())
    0.5
    """

    extent: Extent
    p: np.ndarray

    def __post_init__(self) -> None:
        p = np.asarray(self.p, dtype=float)
        n = len(feature_index(self.extent))
        if p.shape != (n,):
            raise InputError(f"priors must have shape ({n},) for extent {self.extent}",
                             field="p", value=p.shape)
        if not np.all((p > 0) & (p < 1)):
            bad = p[~((p > 0) & (p < 1))][0]
            raise InputError("priors must be in (0, 1)", field="p", value=float(bad))
        p = p.copy()
        p.setflags(write=False)
        object.__setattr__(self, "p", p)

    @classmethod
    def uniform(cls, extent: Extent) -> Evidence:
        return cls(extent, np.full(len(feature_index(extent)), 0.5))

    @property
    def judged(self) -> np.ndarray:
        """``(N,) bool``: features with evidence (p ≠ ½)."""
        return self.p != 0.5

    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-feature ``log p`` (present) and ``log(1 - p)`` (absent), each ``(N,)``."""
        p = np.clip(self.p, P_MIN, 1 - P_MIN)
        return np.log(p), np.log1p(-p)

    def log_probability(self, structure: Structure | np.ndarray) -> float:
        """``Σ_f log p_f(g_f(Z))`` of a structure (or occupancy array)."""
        z = structure.occupancy if isinstance(structure, Structure) else structure
        g = feature_values(self.extent, z)
        lp, lq = self.weights()
        return float(np.sum(np.where(g, lp, lq)))

    def with_priors(self, p: np.ndarray) -> Evidence:
        return Evidence(self.extent, p)

    def masked(self, keep: np.ndarray) -> Evidence:
        """Evidence where features outside ``keep`` ((N,) bool) are set to ½."""
        return Evidence(self.extent, np.where(keep, self.p, 0.5))


def evidence_to_json(evidence: Evidence) -> dict[str, Any]:
    idx = feature_index(evidence.extent)
    items = [
        {"kind": FeatureKind(int(idx.kind[n])).label, "at": idx.at[n].tolist(),
         "p": float(evidence.p[n])}
        for n in np.flatnonzero(evidence.judged)
    ]
    return {"format": EVIDENCE_FORMAT, "extent": evidence.extent.as_list(), "features": items}


def evidence_from_json(data: Any, *, file: Any = None) -> Evidence:
    """Validate parsed evidence JSON; errors name the file, the field and the value."""
    check_format(data, EVIDENCE_FORMAT, file=file)
    extent = Extent.parse(require(data, "extent", file=file), file=file)
    items = require(data, "features", file=file)
    if not isinstance(items, list):
        raise InputError("must be a list", file=file, field="features", value=items)
    idx = feature_index(extent)
    p = np.full(len(idx), 0.5)
    seen: dict[int, int] = {}
    for n, item in enumerate(items):
        where = f"features[{n}]"
        if not isinstance(item, dict):
            raise InputError("must be an object {kind, at, p}", file=file, field=where,
                             value=item)
        kind = FeatureKind.parse(require(item, "kind", file=file, prefix=f"{where}."), file=file,
                                 field=f"{where}.kind")
        at = require(item, "at", file=file, prefix=f"{where}.")
        if not (isinstance(at, list) and len(at) == 3
                and all(isinstance(a, int) and not isinstance(a, bool) for a in at)):
            raise InputError("must be [i, j, k] (whole numbers)", file=file, field=f"{where}.at",
                             value=at)
        try:
            f = idx.lookup(kind, tuple(at))
        except InputError as err:
            raise InputError(err.message, file=file, field=f"{where}.at", value=at) from None
        prob = require(item, "p", file=file, prefix=f"{where}.")
        if isinstance(prob, bool) or not isinstance(prob, (int, float)) or not 0 < prob < 1:
            raise InputError("must be a probability in (0, 1)", file=file, field=f"{where}.p",
                             value=prob)
        if f in seen:
            raise InputError(f"repeats features[{seen[f]}]", file=file, field=where,
                             value={"kind": kind.label, "at": at})
        seen[f] = n
        p[f] = float(prob)
    return Evidence(extent, p)


def load_evidence(path: str | Path) -> Evidence:
    return evidence_from_json(read_json(path), file=path)


def save_evidence(evidence: Evidence, path: str | Path) -> None:
    write_json(path, evidence_to_json(evidence), indent=None)


def simulate_evidence(structure: Structure, *, accuracy: float = 0.85,
                      occluded_fraction: float = 0.4, seed: int | None = 0,
                      confidence: tuple[float, float] = (0.6, 0.95)) -> Evidence:
    """Evidence from an imperfect detector, for research without images.

    Each feature is occluded (p = ½) with probability ``occluded_fraction``;
    each other feature's detector is right with probability ``accuracy`` and
    reports a prior drawn uniformly from ``confidence`` for the value it
    believes.

    Parameters
    ----------
    structure : Structure
        The truth.
    accuracy : float in [0, 1]
    occluded_fraction : float in [0, 1]
    seed : int or None
        Same seed, same evidence.

    Examples
    --------
    >>> from unseeable.domain import Structure, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(0, (0, 0), 2)])
    >>> e = simulate_evidence(s, accuracy=1.0, occluded_fraction=0.0, seed=1)
    >>> bool(((e.p > 0.5) == feature_values(s.extent, s.occupancy)).all())
    True
    """
    for name, v in (("accuracy", accuracy), ("occluded_fraction", occluded_fraction)):
        if not 0.0 <= v <= 1.0:
            raise InputError("must be in [0, 1]", field=name, value=v)
    lo, hi = confidence
    if not 0.5 < lo <= hi < 1.0:
        raise InputError("must satisfy 0.5 < lo <= hi < 1", field="confidence", value=confidence)
    rng = np.random.default_rng(seed)
    truth = feature_values(structure.extent, structure.occupancy)
    n = len(truth)
    right = rng.random(n) < accuracy
    believed = np.where(right, truth, ~truth)
    strength = rng.uniform(lo, hi, n)
    p = np.where(believed, strength, 1.0 - strength)
    occluded = rng.random(n) < occluded_fraction
    p[occluded] = 0.5
    return Evidence(structure.extent, p)
