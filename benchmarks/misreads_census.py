"""Confident misreads of visible features, and the geometry around each.

With the pose known (polished on the image as the pipeline does), every judged
feature the truth makes visible is read by the detectors; a *confident misread* is
one whose reading disagrees with the truth although ``|p - 1/2| > --margin``. For
each it records the feature's kind, its layer and position, the probability from
the plain models (``p``) and from the context models under the true structure
(``p_ctx``, what the estimator uses once its estimate is right), and the geometry
around it in the image:

* for a segment, the silhouette edge (upper or lower) of a *foreign* log of the
  true structure (not one of the feature's own logs, at layers j and j - 2 over
  the stretch) lying nearest the detector stretch and nearly parallel to it
  (within ``--angle`` degrees, overlapping it along its line): its layer offset,
  whether it lies on the same grid line, the image distance (px) and angle;
* for an end, the nearest present end of the truth in the image (px, in units of
  the misread ellipse's semi-major axis), and whether a log at layer j ± 2 on the
  same grid line ends or joins at the same position.

Usage::

    python benchmarks/misreads_census.py --corpus DIR --out /tmp/c.json
    python benchmarks/misreads_census.py --family validation --scenes 40 --out /tmp/v.json
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from corpus_views import add_view_arguments, map_views, views_from_args  # noqa: E402

#: Census threshold: a foreign silhouette within this many projected log radii.
REL = 1.0

KIND_NAMES = {0: "end-", 1: "end+", 2: "u", 3: "v", 4: "w"}


def log_silhouettes(structure, pose, camera, geometry):
    """Image lines of each log's lower and upper silhouettes.

    Returns
    -------
    lines : (2L, 2, 2) float
        Lower silhouettes of every log, then upper ones.
    layers, along : (2L,) int
        The log's layer and its fixed grid coordinate (k on even layers, i on odd ones).
    spans : list of (int, int)
        The log's first and last position along its axis.
    """
    from unseeable.domain import lower_silhouette
    from unseeable.vision.projection import upper_silhouette

    g = geometry
    starts, stops, layers, along, spans = [], [], [], [], []
    for log in structure.logs:
        pos = np.array(log.positions(), dtype=float)
        j = log.layer
        axis = np.array([1.0, 0, 0]) if j % 2 == 0 else np.array([0, 0, 1.0])
        y = g.layer_height(np.array([j]))[0]
        a = np.array([pos[0, 0] * g.l1, y, pos[0, 2] * g.l1]) - g.l3 * axis
        b = np.array([pos[-1, 0] * g.l1, y, pos[-1, 2] * g.l1]) + g.l3 * axis
        starts.append(a)
        stops.append(b)
        layers.append(j)
        along.append(int(pos[0, 2]) if j % 2 == 0 else int(pos[0, 0]))
        first = int(pos[0, 0]) if j % 2 == 0 else int(pos[0, 2])
        spans.append((first, first + len(pos) - 1))
    if not starts:
        return np.zeros((0, 2, 2)), np.zeros(0, int), np.zeros(0, int), []
    a = pose.grid_to_world(np.array(starts))
    b = pose.grid_to_world(np.array(stops))
    la, lb = lower_silhouette(a, b, camera.centre, g.radius)
    ua, ub = upper_silhouette(a, b, camera.centre, g.radius)
    lower = camera.project(np.stack([la, lb], axis=1))
    upper = camera.project(np.stack([ua, ub], axis=1))
    return (np.concatenate([lower, upper]), np.array(layers * 2), np.array(along * 2),
            spans * 2)


def nearest_parallel(stretch, lines, *, angle_deg):
    """For one detector stretch (2, 2): distance (px), angle (deg) and overlap share of
    each line; distance inf where not parallel within ``angle_deg`` or not overlapping."""
    p, q = stretch
    d = q - p
    length = np.linalg.norm(d)
    u = d / max(length, 1e-9)
    a, b = lines[:, 0], lines[:, 1]
    e = b - a
    le = np.linalg.norm(e, axis=1)
    ue = e / np.maximum(le, 1e-9)[:, None]
    cos = np.clip(np.abs(ue @ u), 0, 1)
    angle = np.degrees(np.arccos(cos))
    n = np.stack([-ue[:, 1], ue[:, 0]], axis=1)
    mid = (p + q) / 2
    dist = np.abs(np.einsum("ij,ij->i", mid[None] - a, n))
    # overlap of the stretch with the line, measured along the stretch
    ta = (a - p) @ u
    tb = (b - p) @ u
    lo = np.maximum(np.minimum(ta, tb), 0.0)
    hi = np.minimum(np.maximum(ta, tb), length)
    overlap = np.clip(hi - lo, 0, None) / max(length, 1e-9)
    ok = (angle < angle_deg) & (overlap > 0.3)
    return np.where(ok, dist, np.inf), angle, overlap


def foreign_edges(proj, idx, seg, lines, layers, along, spans, nlog, *, angle_deg):
    """Nearest parallel foreign silhouette of every feature in ``seg`` (segment indices).

    Returns distance (px), the line index (-1 none) per feature."""
    dist = np.full(len(seg), np.inf)
    best = np.full(len(seg), -1)
    for n, f in enumerate(seg):
        i, j, k = (int(x) for x in idx.at[f])
        pos_along = i if j % 2 == 0 else k
        line_coord = k if j % 2 == 0 else i
        d, _, _ = nearest_parallel(proj.detector_segments[f], lines, angle_deg=angle_deg)
        for m in range(len(lines)):
            lo, hi = spans[m]
            on = along[m] == line_coord and lo - 1 <= pos_along <= hi + 1
            if on and ((m < nlog and layers[m] == j) or (m >= nlog and layers[m] == j - 2)):
                d[m] = np.inf
        if np.isfinite(d).any():
            best[n] = int(np.argmin(d))
            dist[n] = d[best[n]]
    return dist, best


def px_per_radius(proj, camera, geometry):
    """(N,) projected log radius (px) at each feature's centre."""
    c = np.asarray(proj.centres_world, float)
    up = c + np.array([0.0, geometry.radius, 0.0])
    return np.linalg.norm(camera.project(up) - camera.project(c), axis=-1)


def view_misreads(task):
    """The confident misreads of one view (with the pose known)."""
    source, margin, angle_deg = task
    from unseeable.domain import LogGeometry, feature_index, feature_values
    from unseeable.visibility import background_context
    from unseeable.vision import detect_features

    g = LogGeometry()
    tv = source.load()
    view = tv.view
    det = detect_features(view.image, view.camera, tv.pose, view.extent, refine=True)
    extent = view.extent
    idx = feature_index(extent)
    truth = feature_values(extent, tv.truth.occupancy).astype(bool)
    p = det.p
    p_ctx = p
    if det.has_context:
        behind = background_context(tv.truth, view.camera.centre, det.pose, geometry=g)
        p_ctx = det.priors_given(behind)
    proj = det.scores.projection
    seen = det.judged & tv.visible
    wrong = seen & (np.abs(p_ctx - 0.5) > margin) & ((p_ctx > 0.5) != truth)
    wrong_plain = seen & (np.abs(p - 0.5) > margin) & ((p > 0.5) != truth)
    lines, layers, along, spans = log_silhouettes(tv.truth, det.pose, view.camera, g)
    nlog = len(tv.truth.logs)
    radius_px = px_per_radius(proj, view.camera, g)
    seg = np.flatnonzero(seen & ~proj.is_end & np.isfinite(proj.detector_segments[:, 0, 0]))
    sdist, sbest = (foreign_edges(proj, idx, seg, lines, layers, along, spans, nlog,
                                  angle_deg=angle_deg) if len(lines)
                    else (np.full(len(seg), np.inf), np.full(len(seg), -1)))
    rel = sdist / np.maximum(radius_px[seg], 1e-9)
    # What the prototype rules of benchmarks/misreads_aliases.py see: any edge within
    # reach (structure-free), and one the true structure draws (explained away).
    from misreads_aliases import edge_presence

    from unseeable.vision.projection import parallel_edge_pairs

    edges = edge_presence(tv.truth)
    near = {}
    for reach in (4.0, 6.0):
        f1, g1, up1 = parallel_edge_pairs(proj, det.judged, reach_px=reach)
        anyp = np.zeros(len(idx), bool)
        anyp[f1] = True
        held = edges[g1, up1.astype(int)] & tv.visible[g1]
        truep = np.zeros(len(idx), bool)
        truep[f1[held]] = True
        near[reach] = (anyp, truep)
    all_segments = [{"rel": (round(float(rel[n]), 2) if np.isfinite(rel[n]) else None),
                     "px": (round(float(sdist[n]), 2) if np.isfinite(sdist[n]) else None),
                     "truth": bool(truth[f]), "p_ctx": round(float(p_ctx[f]), 3),
                     "kind": KIND_NAMES[int(idx.kind[f])],
                     "any4": bool(near[4.0][0][f]), "true4": bool(near[4.0][1][f]),
                     "any6": bool(near[6.0][0][f]), "true6": bool(near[6.0][1][f]),
                     "dj": (int(layers[sbest[n]] - idx.at[f, 1]) if sbest[n] >= 0 else None),
                     "side": (None if sbest[n] < 0 else "lower" if sbest[n] < nlog else "upper")}
                    for n, f in enumerate(seg)]
    out = []
    for f in np.flatnonzero(wrong | wrong_plain):
        i, j, k = (int(x) for x in idx.at[f])
        kind = int(idx.kind[f])
        pos_along = i if j % 2 == 0 else k
        line_coord = k if j % 2 == 0 else i
        rec = {"view": source.label, "feature": int(f), "kind": KIND_NAMES[kind],
               "at": [i, j, k], "truth": bool(truth[f]), "p": round(float(p[f]), 3),
               "p_ctx": round(float(p_ctx[f]), 3), "ctx_wrong": bool(wrong[f]),
               "plain_wrong": bool(wrong_plain[f])}
        if kind >= 2 and len(lines):
            stretch = proj.detector_segments[f]
            dist, ang, _ = nearest_parallel(stretch, lines, angle_deg=angle_deg)
            # own logs: layer j (lower silhouette) and j - 2 (upper) covering the position
            own = np.zeros(len(lines), bool)
            for n in range(len(lines)):
                lo, hi = spans[n]
                on = along[n] == line_coord and lo - 1 <= pos_along <= hi + 1
                own[n] = on and ((n < nlog and layers[n] == j)
                                 or (n >= nlog and layers[n] == j - 2))
            dist = np.where(own, np.inf, dist)
            best = int(np.argmin(dist)) if np.isfinite(dist).any() else None
            if best is not None:
                rec.update({"edge_px": round(float(dist[best]), 1),
                            "edge_angle": round(float(ang[best]), 1),
                            "edge_layer_offset": int(layers[best] - j),
                            "edge_side": "lower" if best < nlog else "upper",
                            "edge_same_line": bool(along[best] == line_coord
                                                   and layers[best] % 2 == j % 2)})
            rec["stretch_px"] = round(float(np.linalg.norm(stretch[1] - stretch[0])), 1)
            rec["radius_px"] = round(float(radius_px[f]), 1)
            if "edge_px" in rec:
                rec["edge_rel"] = round(rec["edge_px"] / max(rec["radius_px"], 1e-9), 2)
        elif kind < 2:
            ell = proj.ellipses
            present_end = (idx.kind <= 1) & truth & np.isfinite(ell[:, 0])
            present_end[f] = False
            if present_end.any():
                dd = np.linalg.norm(ell[present_end, :2] - ell[f, :2], axis=1)
                rec["nearest_end_axes"] = round(float(dd.min() / max(ell[f, 2], 1e-9)), 2)
            # a log on the same grid line two layers up or down with a notch here
            occ = np.asarray(tv.truth.occupancy)
            near = []
            for dj in (-2, 2):
                jj = j + dj
                if 0 <= jj < extent.J and occ[i, jj, k] != 0:
                    near.append(dj)
            rec["log_pm2_here"] = near
        out.append(rec)
    return {"view": source.label, "judged_visible": int(seen.sum()),
            "misreads": out, "segments": all_segments}


def classify(rec) -> str:
    """The census class of one misread."""
    if rec["kind"].startswith("end"):
        if rec.get("log_pm2_here"):
            return "end: log at j±2 here"
        return "end: other"
    if "edge_rel" in rec and rec["edge_rel"] < REL:
        tag = "same line" if rec["edge_same_line"] else "other line"
        dj = rec["edge_layer_offset"]
        return f"segment: foreign {rec['edge_side']} edge < {REL} r ({tag}, Δj={dj:+d})"
    return f"segment: no parallel foreign edge < {REL} r"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_arguments(parser, families=True, workers=1)
    parser.add_argument("--margin", type=float, default=0.4, help="|p - 1/2| above this")
    parser.add_argument("--angle", type=float, default=8.0, help="parallel within (deg)")
    parser.add_argument("--out", type=Path, help="JSON records")
    args = parser.parse_args(argv)
    views = views_from_args(parser, args)
    results = map_views(view_misreads, [(v, args.margin, args.angle) for v in views],
                        workers=args.workers, description="reading")
    recs = [r for res in results for r in res["misreads"]]
    judged = sum(res["judged_visible"] for res in results)
    ctx = [r for r in recs if r["ctx_wrong"]]
    plain = [r for r in recs if r["plain_wrong"]]
    print(f"{len(views)} views, {judged} visible judged features; confident misreads: "
          f"{len(plain)} plain models, {len(ctx)} context models under the truth")
    for name, group in (("plain", plain), ("context", ctx)):
        c = Counter(classify(r) for r in group)
        print(f"-- {name}:")
        for cls, n in c.most_common():
            pres = sum(1 for r in group if classify(r) == cls and not r["truth"])
            print(f"  {n:4d}  {cls}  (read present, truth absent: {pres})")
    segs = [r for res in results for r in res["segments"]]
    rel = np.array([np.inf if r["rel"] is None else r["rel"] for r in segs])
    conf_wrong = np.array([abs(r["p_ctx"] - 0.5) > args.margin and (r["p_ctx"] > 0.5) != r["truth"]
                           for r in segs])
    absent = np.array([not r["truth"] for r in segs])
    print("-- visible judged segments by nearest parallel foreign silhouette (context models):")
    for lo, hi in ((0, 0.5), (0.5, 1.0), (1.0, 1.5), (1.5, 2.5), (2.5, np.inf)):
        m = (rel >= lo) & (rel < hi)
        if hi == np.inf:
            m |= ~np.isfinite(rel)
        fp = (m & conf_wrong & absent).sum()
        print(f"  [{lo}, {hi}) r: {m.sum():5d} segments ({(m & absent).sum()} absent), "
              f"{(m & conf_wrong).sum():3d} confident misreads "
              f"({fp} read present wrongly; "
              f"rate among absent {fp / max((m & absent).sum(), 1):.1%})")
    print("-- pairs of the prototype (parallel_edge_pairs): share of visible judged segments,"
          " and of the confident false presents:")
    fpm = conf_wrong & absent
    for key in ("any4", "true4", "any6", "true6"):
        v = np.array([r[key] for r in segs])
        print(f"  {key}: {v.mean():.1%} of segments ({(v & absent).sum()} absent), "
              f"{(v & fpm).sum()} of {fpm.sum()} false presents")
    px = np.array([np.inf if r["px"] is None else r["px"] for r in segs])
    print("-- the same by image distance (px; a segment detector searches 3 px + 1 across):")
    for lo, hi in ((0, 4), (4, 6), (6, 10), (10, np.inf)):
        m = (px >= lo) & (px < hi)
        if hi == np.inf:
            m |= ~np.isfinite(px)
        fp = (m & conf_wrong & absent).sum()
        print(f"  [{lo}, {hi}) px: {m.sum():5d} segments ({(m & absent).sum()} absent), "
              f"{fp:3d} read present wrongly (rate among absent "
              f"{fp / max((m & absent).sum(), 1):.1%})")
    if args.out:
        args.out.write_text(json.dumps({"views": len(views), "judged": judged,
                                        "records": recs}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
