"""End-to-end estimation: evidence or views in, an :class:`Estimate` out.

This is the orchestration layer the command line calls: it strings the
stages together (pose → evidence → visibility ⇄ structure → confidence) and
writes the estimate file (DESIGN.md §6, ``unseeable/estimate@1``).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.domain.evidence import Evidence
from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.domain.frames import GridPose
from unseeable.domain.io import structure_to_json
from unseeable.domain.structure import Structure
from unseeable.fileio import write_json

__all__ = ["Estimate", "estimate_evidence", "estimate_to_json", "write_estimate",
           "ESTIMATE_FORMAT", "log_support"]

logger = logging.getLogger(__name__)

ESTIMATE_FORMAT = "unseeable/estimate@1"


@dataclass(frozen=True, eq=False)
class Estimate:
    """A structure estimate with everything needed to judge and explain it.

    Attributes
    ----------
    result : SolveResult
        The MAP solve that produced the structure.
    priors : (N,) float
        The evidence the kept structure was estimated under (½ = none).
    visible : (N,) bool or None
        Per-feature visibility used (None for bare evidence files).
    confidence : Confidence or None
    pose : GridPose or None
        The pose used (given or estimated), when images were used.
    iterations, converged, cycle_length
        Of the visibility fixpoint (1, True, 0 without one).
    timings : dict
        Seconds per stage.
    extra : dict
        Stage-specific details written to the estimate file (e.g. pose quality).
    """

    result: Any
    priors: np.ndarray
    visible: np.ndarray | None = None
    confidence: Any = None
    pose: GridPose | None = None
    iterations: int = 1
    converged: bool = True
    cycle_length: int = 0
    timings: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def structure(self) -> Structure:
        return self.result.structure

    @property
    def confident(self) -> bool | None:
        return None if self.confidence is None else self.confidence.confident


def log_support(structure: Structure, priors: np.ndarray) -> np.ndarray:
    """Whether each log of ``structure`` has direct evidence: a judged feature of its own.

    A log is "seen" when one of its end features or the u/v/w segments along its
    notches carries evidence (p ≠ ½); otherwise the grammar inferred it.

    Returns
    -------
    (L,) bool, in ``structure.logs`` order.
    """
    idx = feature_index(structure.extent)
    judged = np.asarray(priors) != 0.5
    seen = np.zeros(len(structure.logs), dtype=bool)
    for n, log in enumerate(structure.logs):
        pos = log.positions()
        kinds, ats = [], []
        kinds.append(FeatureKind.END_MINUS)
        ats.append(pos[0])
        kinds.append(FeatureKind.END_PLUS)
        ats.append(pos[-1])
        for q in pos:
            for kind in (FeatureKind.U, FeatureKind.V):
                kinds.append(kind)
                ats.append(q)
        for q in pos[:-1]:
            kinds.append(FeatureKind.W)
            ats.append(q)
        f = idx.lookup_many(np.array(kinds), np.array(ats))
        seen[n] = bool(judged[f].any())
    return seen


def estimate_evidence(evidence: Evidence, *, backend: str = "cpsat", constraints=(),
                      confidence: bool = True, delta_star: float = 0.2,
                      tolerance: bool = True, time_limit: float = 60.0,
                      workers: int = 1) -> Estimate:
    """MAP structure for bare evidence, with its confidence.

    Features without evidence (p = ½) count as occluded for the confidence test.

    Examples
    --------
    >>> from unseeable.domain import Extent, Log, Structure, simulate_evidence
    >>> truth = Structure(Extent(2, 1, 2), [Log(0, (0, 0), 2), Log(0, (0, 1), 2)])
    >>> ev = simulate_evidence(truth, accuracy=1.0, occluded_fraction=0.0, seed=0)
    >>> est = estimate_evidence(ev)
    >>> est.structure == truth, est.confident
    (True, True)
    """
    from unseeable.confidence import assess_confidence
    from unseeable.grammar import EvidenceTerm
    from unseeable.solve import StructureSolver

    t0 = time.perf_counter()
    solver = StructureSolver(evidence.extent, constraints=constraints, backend=backend,
                             workers=workers)
    terms = [EvidenceTerm(evidence)]
    result = solver.solve(terms, time_limit=time_limit)
    timings = {"estimate_s": time.perf_counter() - t0}
    conf = None
    if confidence and result.structure is not None:
        t1 = time.perf_counter()
        conf = assess_confidence(solver, terms, result, ~evidence.judged, delta_star=delta_star,
                                 tolerance=tolerance, time_limit=time_limit)
        timings["confidence_s"] = time.perf_counter() - t1
    timings["total_s"] = time.perf_counter() - t0
    return Estimate(result=result, priors=evidence.p, confidence=conf, timings=timings)


def estimate_to_json(estimate: Estimate, *, features: bool = True) -> dict[str, Any]:
    """The estimate file's content (DESIGN.md §6)."""
    r = estimate.result
    data: dict[str, Any] = {
        "format": ESTIMATE_FORMAT,
        "status": r.status.value,
        "structure": None if r.structure is None else structure_to_json(r.structure),
        "log_probability": r.log_probability,
        "bound": r.bound,
        "backend": r.backend,
    }
    if estimate.pose is not None:
        data["pose"] = estimate.pose.to_json()
    if estimate.confidence is not None:
        data.update({
            "confident": estimate.confidence.confident,
            "tolerance": estimate.confidence.tolerance,
            "delta_star": estimate.confidence.delta_star,
            "occluded_features": estimate.confidence.occluded,
        })
    data["iterations"] = estimate.iterations
    data["converged"] = estimate.converged
    data["cycle_length"] = estimate.cycle_length
    data["timings"] = {**estimate.timings, "solver": r.timings}
    if r.choices:
        data["choices"] = r.choices
    if r.structure is not None:
        seen = log_support(r.structure, estimate.priors)
        data["logs_seen"] = seen.tolist()
    data.update(estimate.extra)
    if features and r.structure is not None:
        idx = feature_index(r.structure.extent)
        value = feature_values(r.structure.extent, r.structure.occupancy)
        vis = estimate.visible
        items = []
        for n in range(len(idx)):
            item = {"kind": FeatureKind(int(idx.kind[n])).label, "at": idx.at[n].tolist(),
                    "p": float(estimate.priors[n]), "value": bool(value[n])}
            if vis is not None:
                item["visible"] = bool(vis[n])
            items.append(item)
        data["features"] = items
    return data


def write_estimate(estimate: Estimate, out_dir: str | Path) -> Path:
    """Write ``out_dir/estimate.json`` atomically and return its path."""
    path = Path(out_dir) / "estimate.json"
    write_json(path, estimate_to_json(estimate), indent=1)
    return path


def estimate_file(path: str | Path, data: Any, *, out_dir: str | Path | None = None,
                  backend: str = "cpsat", delta_star: float = 0.2, tolerance: bool = True,
                  time_limit: float = 60.0, truth: Structure | None = None,
                  ) -> tuple[Estimate, list[Path]]:
    """Estimate from a parsed evidence or view file, told apart by its format tag.

    Returns the estimate and the pictures written to ``out_dir`` (views only).
    """
    from unseeable.domain.evidence import EVIDENCE_FORMAT, evidence_from_json
    from unseeable.errors import InputError

    fmt = data.get("format") if isinstance(data, dict) else None
    if fmt == EVIDENCE_FORMAT:
        evidence = evidence_from_json(data, file=path)
        est = estimate_evidence(evidence, backend=backend, delta_star=delta_star,
                                tolerance=tolerance, time_limit=time_limit)
        return est, []
    if fmt == "unseeable/view@1":
        return _estimate_view_file(path, out_dir=out_dir, backend=backend,
                                   delta_star=delta_star, tolerance=tolerance,
                                   time_limit=time_limit, truth=truth)
    raise InputError(f"must be {EVIDENCE_FORMAT!r} or 'unseeable/view@1'", file=path,
                     field="format", value=fmt)


def _estimate_view_file(path, **kwargs):
    from unseeable.errors import InputError

    raise InputError("view files are not supported yet", file=path, field="format",
                     value="unseeable/view@1")
