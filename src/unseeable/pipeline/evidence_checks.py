"""What the detections say about an estimate beyond its probability: which logs were
seen, whether the extent or the pose is in doubt, which segment features share an
image line."""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import numpy as np

from unseeable.domain.features import FeatureKind, feature_index, feature_values
from unseeable.domain.structure import Structure
from unseeable.errors import InputError

if TYPE_CHECKING:
    from unseeable.visibility.loop import LineAliases
    from unseeable.vision.evidence import FeatureDetection

__all__ = ["log_support", "boundary_ends", "line_aliases", "presence_doubt",
           "EDGE_ENDS_ABSENT_MIN", "EDGE_ENDS_ABSENT_SHARE", "PRESENCE_SHIFT_DOUBT"]

#: An estimate's extent is in doubt when at least this many of the log ends it puts on the
#: extent's boundary, and at least :data:`EDGE_ENDS_ABSENT_SHARE` of those judged, are
#: judged absent (:func:`boundary_ends`): the assembly may go on beyond the extent, or the
#: grid be off it (docs/decisions.md).
EDGE_ENDS_ABSENT_MIN = 2
EDGE_ENDS_ABSENT_SHARE = 0.25
#: An estimate's evidence is in doubt when the detections' log-odds had to be shifted
#: this far (nats) towards absent to agree with it (the presence shift,
#: :func:`~unseeable.visibility.loop.fit_presence_shift`): the photograph shows much
#: more than any structure the grammar builds on this grid, as when the grid is off the
#: assembly. Set beyond every rightly posed view measured (down to -1.4, seen by other
#: cameras); the wrong poses it catches shift by -1.6 to -4.7 (docs/decisions.md). The
#: shift applied stops at :data:`~unseeable.visibility.loop.PRESENCE_SHIFT_BOUND`; the
#: doubt reads the fitted one (:func:`presence_doubt`).
PRESENCE_SHIFT_DOUBT = -1.5


def presence_doubt(fixpoint, view: int = 0) -> bool:
    """Whether a view's evidence is in doubt by its presence shift.

    In doubt when the shift fitted to the estimate (unbounded, applied or not) is
    :data:`PRESENCE_SHIFT_DOUBT` or further towards absent (the image shows more than
    the estimate builds), or beyond
    :data:`~unseeable.visibility.loop.PRESENCE_SHIFT_BOUND` towards present (it shows
    far less), or when the fixpoint refused the shift because the estimate under it
    dropped most of what the detections see clearly
    (:attr:`~unseeable.visibility.loop.VisibilityFixpoint.presence_refused`): the
    detections and every structure on the grid disagree more than a look explains.

    Parameters
    ----------
    fixpoint : VisibilityFixpoint
        Of :func:`~unseeable.visibility.estimate_with_visibility`.
    view : int
        The view's index among the fixpoint's observations.

    Returns
    -------
    bool
    """
    from unseeable.visibility.loop import PRESENCE_SHIFT_BOUND

    fitted = fixpoint.presence_fitted or fixpoint.presence_shift
    refused = fixpoint.presence_refused
    shift = float(fitted[view]) if fitted else 0.0
    return bool((refused and refused[view]) or shift <= PRESENCE_SHIFT_DOUBT
                or shift > PRESENCE_SHIFT_BOUND)


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


def boundary_ends(structure: Structure, priors: np.ndarray) -> tuple[int, int]:
    """The log ends ``structure`` puts on its extent's boundary that the evidence judged,
    and how many of those it judged absent.

    A log whose first notch is the first position along its axis (or whose
    last is the last) ends at the extent's edge. When the assembly is larger
    than the extent, its logs go on there and the end detectors see a log's
    side rather than its end disc: such ends are judged absent (p < ½), as
    they are when the grid is off the assembly. With the pose estimated, the
    doubt rule of :func:`~unseeable.pipeline.find_pose` (:data:`EDGE_ENDS_ABSENT_MIN`,
    :data:`EDGE_ENDS_ABSENT_SHARE`) held for 14 of 54 corpus views given an
    extent one position short each way; with the right extent for 12 of 579
    corpus and family views, 8 of them posed 7 mm or more off (of 27 so posed)
    and 4 posed right (docs/decisions.md).

    Parameters
    ----------
    structure : Structure
    priors : (N,) float
        Per feature of ``structure.extent`` (½ = not judged).

    Returns
    -------
    judged, absent : int

    Examples
    --------
    >>> from unseeable.domain import Extent, Log
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> p = np.full(len(feature_index(s.extent)), 0.5)
    >>> p[0], p[3] = 0.9, 0.1  # its end at i = 0 judged present, its end at i = 1 absent
    >>> boundary_ends(s, p)
    (2, 1)
    """
    extent = structure.extent
    priors = np.asarray(priors, dtype=float)
    idx = feature_index(extent)
    if priors.shape != (len(idx),):
        raise InputError(f"must have one prior per feature of {extent}", field="priors",
                         value=priors.shape)
    along_i = idx.at[:, 1] % 2 == 0  # Extent.axis: even layers run along i
    position = np.where(along_i, idx.at[:, 0], idx.at[:, 2])
    last = np.where(along_i, extent.I, extent.K) - 1
    at_edge = (((idx.kind == FeatureKind.END_MINUS) & (position == 0))
               | ((idx.kind == FeatureKind.END_PLUS) & (position == last)))
    judged = at_edge & feature_values(extent, structure.occupancy) & (priors != 0.5)
    return int(judged.sum()), int((judged & (priors < 0.5)).sum())


#: Each detection's line aliases, kept while the detection lives: an estimate continued
#: with more views (:func:`~unseeable.pipeline.extend_estimate`) reads its earlier views'
#: detections again, and pairing a large assembly's segments takes a quarter second.
_LINE_ALIASES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def line_aliases(det: FeatureDetection, camera) -> LineAliases:
    """The segment features of a detection that share image lines
    (:func:`~unseeable.vision.projection.collinear_segment_pairs`), with their distances
    from ``camera``'s centre."""
    from unseeable.visibility.loop import LineAliases
    from unseeable.vision.projection import collinear_segment_pairs

    centre = np.asarray(camera.centre, dtype=float)
    kept = _LINE_ALIASES.get(det)
    if kept is not None and np.array_equal(kept[0], centre):
        return kept[1]
    projection = det.scores.projection
    first, second = collinear_segment_pairs(projection, det.judged)
    distance = np.linalg.norm(projection.centres_world - centre, axis=1)
    aliases = LineAliases(first, second, distance)
    for kept_array in (aliases.first, aliases.second, aliases.distance):
        kept_array.setflags(write=False)  # shared by every estimate that reads ``det``
    _LINE_ALIASES[det] = (centre.copy(), aliases)
    return aliases
