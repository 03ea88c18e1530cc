r"""The estimate page's HTML, style and script (one template, everything inline).

The script is a small canvas renderer written for this page: logs are 12-sided
prisms cut into short pieces (at every notch slot's edges, so crossing logs sort
well), projected in perspective and painted back to front with flat shading;
the table, its grid and the logs' shadows are painted first. A plan of the table
(turned with the view) shows where the cameras stand. Drag orbits, shift- or
right-drag pans, the wheel zooms, double-click resets, a click on a log shows its
evidence (its features drawn over the scene in their evidence's colour).

In the address, ``#log=N`` opens log ``N``'s evidence, ``#mode=evidence`` colours
the logs seen/inferred even with the truth, and ``#view=all`` frames the cameras
too (the keys f and a switch between framing the assembly and all).

The page fills ``#status`` (hidden) with what it did: ``data-drawn`` (frames
drawn), ``data-faces`` (faces painted in the last frame), ``data-logs``,
``data-cameras`` and ``data-notes`` (what it was given), ``data-errors`` (script
errors, empty when none) and, with ``#selftest`` in the address, the outcome of a
click it makes on the front-most log, a drag and a turn of the wheel
(``data-selftest``).

The template has two placeholders: ``@TITLE@`` (HTML-escaped text) and
``@SCENE@`` (the scene as JSON, safe inside a script element).
"""

from __future__ import annotations

__all__ = ["PAGE_TEMPLATE"]

_STYLE = r"""
* { box-sizing: border-box; }
html, body { margin: 0; height: 100%; overflow: hidden; background: #e8ecf1;
  font: 13px/1.4 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
  color: #1d2533; }
canvas#view { position: absolute; inset: 0; width: 100%; height: 100%; display: block;
  cursor: grab; touch-action: none; }
canvas#view.dragging { cursor: grabbing; }
.card { position: absolute; background: rgba(255, 255, 255, 0.95); border-radius: 8px;
  box-shadow: 0 1px 4px rgba(20, 30, 50, 0.18); padding: 10px 12px; }
#header { left: 12px; top: 12px; max-width: min(620px, calc(100% - 280px)); }
#header h1 { font-size: 15px; margin: 0 0 4px 0; }
#header .line { color: #3b4658; }
#header .good { color: #1d7a32; font-weight: 600; }
#header .bad { color: #b3261e; font-weight: 600; }
#notes { margin-top: 6px; }
#notes div { background: #fff4d6; border: 1px solid #e5c35c; border-radius: 5px;
  padding: 3px 7px; margin-top: 4px; color: #5c4300; }
#legend { right: 12px; top: 12px; width: 250px; }
#legend h2 { font-size: 12px; text-transform: uppercase; letter-spacing: 0.05em;
  color: #5a6577; margin: 0 0 6px 0; }
#legend ul { list-style: none; margin: 0; padding: 0; }
#legend li { display: flex; align-items: center; gap: 8px; margin: 3px 0; }
#legend .count { margin-left: auto; color: #5a6577; font-variant-numeric: tabular-nums; }
.swatch { display: inline-block; width: 22px; height: 11px; border-radius: 6px;
  border: 1px solid rgba(0, 0, 0, 0.25); flex: none; }
.swatch.ghost { opacity: 0.45; border-style: dashed; }
.swatch.line { height: 0; border-radius: 0; border: 0; border-top: 2px solid #243044; }
.modes { display: flex; gap: 4px; margin-bottom: 8px; }
.modes button { flex: 1; font: inherit; font-size: 12px; padding: 3px 4px; border-radius: 5px;
  border: 1px solid #b8c2d0; background: #f5f7fa; cursor: pointer; }
.modes button.on { background: #243044; color: #fff; border-color: #243044; }
#panel { right: 12px; top: 200px; width: 380px; overflow: auto; }
#panel.hidden { display: none; }
#panel h2 { font-size: 15px; margin: 0 24px 6px 0; display: flex; align-items: center;
  gap: 8px; }
#panel h3 { font-size: 12px; text-transform: uppercase; letter-spacing: 0.05em;
  color: #5a6577; margin: 10px 0 4px 0; }
#panel .close { position: absolute; right: 8px; top: 6px; border: 0; background: none;
  font-size: 18px; cursor: pointer; color: #5a6577; }
.badge { display: inline-block; border-radius: 10px; padding: 1px 8px; font-size: 12px;
  font-weight: 600; color: #fff; margin-right: 4px; }
table { border-collapse: collapse; width: 100%; }
table.kv td { padding: 1px 6px 1px 0; vertical-align: top; }
table.kv td:first-child { color: #5a6577; white-space: nowrap; }
table.features th { text-align: left; font-weight: 600; color: #5a6577;
  border-bottom: 1px solid #d5dbe4; padding: 2px 4px; }
table.features td { padding: 2px 4px; border-bottom: 1px solid #eef1f5;
  font-variant-numeric: tabular-nums; }
table.features tr.unjudged td { color: #8a93a3; }
table.features tbody tr:hover td { background: #eef3fb; }
.dot { display: inline-block; width: 10px; height: 10px; border-radius: 50%;
  border: 1px solid rgba(0, 0, 0, 0.3); vertical-align: -1px; }
.explain { color: #5a6577; font-size: 12px; margin: 6px 0 0 0; }
#help { position: absolute; left: 12px; bottom: 10px; max-width: calc(100% - 240px);
  color: #4a5567; font-size: 12px; background: rgba(255, 255, 255, 0.75);
  border-radius: 6px; padding: 3px 8px; }
"""

# Installed before the main script, so that even a syntax error in it is recorded.
_ERROR_TRAP = r"""
(function () {
  var status = document.getElementById("status");
  function record(text) {
    var old = status.getAttribute("data-errors") || "";
    status.setAttribute("data-errors", (old ? old + " | " : "") + text);
  }
  window.addEventListener("error", function (e) {
    record((e.message || "error") + (e.lineno ? " (line " + e.lineno + ")" : ""));
  });
  window.addEventListener("unhandledrejection", function (e) { record(String(e.reason)); });
})();
"""

_SCRIPT = r"""
(function () {
"use strict";
const S = JSON.parse(document.getElementById("scene-data").textContent);
const canvas = document.getElementById("view");
const ctx = canvas.getContext("2d");
const statusEl = document.getElementById("status");

const FOV = 40 * Math.PI / 180;
const NEAR = 1.0;
const COL = {
  seen: [40, 170, 60], inferred: [245, 150, 30], unknown: [140, 150, 165],
  right: [40, 170, 60], wrong: [215, 40, 40], missed: [70, 95, 210],
};
const LABEL = {
  seen: "seen", inferred: "inferred", unknown: "evidence not recorded",
  right: "right", wrong: "wrong", missed: "missed (truth)",
};
const KIND_TEXT = {
  "end-": "log end before its first notch",
  "end+": "log end after its last notch",
  "u": "bottom edge just before a notch",
  "v": "bottom edge just after a notch",
  "w": "bottom edge between two notches",
};
const hasTruth = !!S.truth;
let mode = hasTruth && !/mode=evidence/.test(window.location.hash) ? "truth" : "evidence";
let selected = null;      // {type: "log" | "missed" | "camera", index}
let hoverFeature = -1;

// ---- vectors -------------------------------------------------------------------
function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
function mul(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
function cross(a, b) {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}
function norm(a) { return Math.hypot(a[0], a[1], a[2]); }
function unit(a) { const n = norm(a) || 1; return mul(a, 1 / n); }
function lerp(a, b, t) { return add(a, mul(sub(b, a), t)); }
function rgba(c, a) {
  return "rgba(" + Math.round(c[0]) + "," + Math.round(c[1]) + "," + Math.round(c[2]) + ","
    + (a === undefined ? 1 : a) + ")";
}
function shadeColour(c, s) { return [Math.min(255, c[0] * s), Math.min(255, c[1] * s),
  Math.min(255, c[2] * s)]; }
function mix(c, d, t) { return [c[0] + (d[0] - c[0]) * t, c[1] + (d[1] - c[1]) * t,
  c[2] + (d[2] - c[2]) * t]; }
function fmt(x, digits) { return x === null || x === undefined ? "–" : Number(x).toFixed(digits); }

// ---- logs as faces --------------------------------------------------------------
const R = S.radius, L1 = S.geometry.l1, L3 = S.geometry.l3;
const G = S.grid;
const SIDES = 12;

function breakpoints(length, notches) {
  const cuts = [0, length];
  for (let n = 0; n < notches; n++) {
    const c = L3 + n * L1;
    cuts.push(c - R, c + R);
  }
  cuts.sort(function (a, b) { return a - b; });
  const out = [0];
  for (let m = 1; m < cuts.length; m++) {
    const a = cuts[m - 1], b = cuts[m];
    if (b - a < 1e-6) continue;
    const pieces = Math.max(1, Math.ceil((b - a) / 24));
    for (let p = 1; p <= pieces; p++) out.push(a + (b - a) * p / pieces);
  }
  return out;
}

function cylinderFaces(axis, notches, owner) {
  const a = axis[0], b = axis[1];
  const length = norm(sub(b, a));
  const d = unit(sub(b, a));
  const helper = Math.abs(d[1]) < 0.9 ? [0, 1, 0] : [1, 0, 0];
  const e1 = unit(cross(d, helper)), e2 = unit(cross(e1, d));
  const ts = breakpoints(length, notches);
  const rings = ts.map(function (t) {
    const c = add(a, mul(d, t));
    const ring = [];
    for (let k = 0; k < SIDES; k++) {
      const ang = 2 * Math.PI * k / SIDES;
      ring.push(add(c, add(mul(e1, R * Math.cos(ang)), mul(e2, R * Math.sin(ang)))));
    }
    return ring;
  });
  const faces = [];
  for (let s = 0; s + 1 < rings.length; s++) {
    for (let k = 0; k < SIDES; k++) {
      const k2 = (k + 1) % SIDES, mid = 2 * Math.PI * (k + 0.5) / SIDES;
      const n = add(mul(e1, Math.cos(mid)), mul(e2, Math.sin(mid)));
      faces.push(makeFace([rings[s][k], rings[s][k2], rings[s + 1][k2], rings[s + 1][k]],
        n, owner));
    }
  }
  faces.push(makeFace(rings[0].slice().reverse(), mul(d, -1), owner));
  faces.push(makeFace(rings[rings.length - 1], d, owner));
  return faces;
}

function makeFace(pts, n, owner) {
  let c = [0, 0, 0];
  for (const p of pts) c = add(c, p);
  return {pts: pts, n: n, c: mul(c, 1 / pts.length), owner: owner};
}

const logFaces = [];
S.logs.forEach(function (log, n) {
  for (const f of cylinderFaces(log.axis, log.notches, {type: "log", index: n})) {
    logFaces.push(f);
  }
});
const ghostFaces = [];
S.missed.forEach(function (log, n) {
  for (const f of cylinderFaces(log.axis, log.notches, {type: "missed", index: n})) {
    ghostFaces.push(f);
  }
});

// ---- cameras, lines ---------------------------------------------------------------
function splitLine(a, b, pieces, style) {
  const out = [];
  for (let p = 0; p < pieces; p++) {
    const u = lerp(a, b, p / pieces), v = lerp(a, b, (p + 1) / pieces);
    out.push({a: u, b: v, c: mul(add(u, v), 0.5), style: style});
  }
  return out;
}
const lines = [];
const planes = [];
S.cameras.forEach(function (cam, n) {
  const style = cam.reference
    ? {colour: "#1c2533", width: 1.8}
    : {colour: "#4e5f7c", width: 1.3};
  const c = cam.centre, q = cam.corners;
  for (let m = 0; m < 4; m++) {
    for (const l of splitLine(c, q[m], 8, style)) lines.push(l);
    for (const l of splitLine(q[m], q[(m + 1) % 4], 6, style)) lines.push(l);
  }
  const left = lerp(q[0], q[1], 0.3), right = lerp(q[0], q[1], 0.7);
  planes.push(makeFace([left, cam.roof, right], [0, 0, 0], {type: "camera", index: n}));
  planes[planes.length - 1].fill = cam.reference ? "rgba(28,37,51,0.85)"
    : "rgba(78,95,124,0.75)";
  planes.push(makeFace(q.slice(), [0, 0, 0], {type: "camera", index: n}));
  planes[planes.length - 1].fill = "rgba(90,120,170,0.10)";
});

// The grid frame's axes (i, j up, k), painted in depth order on the table just outside
// the corner of its origin, where the logs do not hide them.
const AXES_AT = sub(G.origin, mul(add(G.i, G.k), L3 + 2 * R));
const AXES = [["i", G.i, "#7b3fa0"], ["j", G.j, "#3a4a60"], ["k", G.k, "#127f8f"]].map(
  function (ax) {
    const tip = add(AXES_AT, mul(ax[1], L1));
    for (const l of splitLine(AXES_AT, tip, 8, {colour: ax[2], width: 2.2})) lines.push(l);
    return {name: ax[0], tip: tip, colour: ax[2]};
  });

// ---- the table ------------------------------------------------------------------
const centre = G.centre;
let tableHalf = 0.75 * Math.max(G.size[0], G.size[2]) + 60;
for (const cam of S.cameras) {
  tableHalf = Math.max(tableHalf, Math.abs(cam.centre[0] - centre[0]) + 80,
    Math.abs(cam.centre[2] - centre[2]) + 80);
}
tableHalf = Math.ceil(tableHalf / 100) * 100;
const tableCorners = [[-1, -1], [1, -1], [1, 1], [-1, 1]].map(function (s) {
  return [centre[0] + s[0] * tableHalf, 0, centre[2] + s[1] * tableHalf];
});
const tableLines = [];
const STEP = 50;
for (let v = Math.ceil((centre[0] - tableHalf) / STEP) * STEP; v <= centre[0] + tableHalf;
  v += STEP) {
  tableLines.push([[v, 0, centre[2] - tableHalf], [v, 0, centre[2] + tableHalf], v % 200 === 0]);
}
for (let v = Math.ceil((centre[2] - tableHalf) / STEP) * STEP; v <= centre[2] + tableHalf;
  v += STEP) {
  tableLines.push([[centre[0] - tableHalf, 0, v], [centre[0] + tableHalf, 0, v], v % 200 === 0]);
}
// Shadows: each log's footprint straight below it.
const shadows = S.logs.map(function (log) {
  const a = [log.axis[0][0], 0, log.axis[0][2]], b = [log.axis[1][0], 0, log.axis[1][2]];
  const side = mul(unit(cross(sub(b, a), [0, 1, 0])), R * 1.1);
  return [add(a, side), add(b, side), sub(b, side), sub(a, side)];
});

// ---- the view ---------------------------------------------------------------------
const view = {target: centre.slice(), az: 0, el: 0, dist: 1};

// The corners of the assembly's box (its extent's footprint, up to its top layer).
const boxCorners = [];
for (const x of [-L3, G.size[0] - L3]) {
  for (const y of [0, G.size[1]]) {
    for (const z of [-L3, G.size[2] - L3]) {
      boxCorners.push(add(G.origin, add(mul(G.i, x), add(mul(G.j, y), mul(G.k, z)))));
    }
  }
}

function viewBasis() {
  const ce = Math.cos(view.el), se = Math.sin(view.el);
  const back = [ce * Math.sin(view.az), se, ce * Math.cos(view.az)];
  const fwd = mul(back, -1), right = unit(cross(fwd, [0, 1, 0]));
  return {eye: add(view.target, mul(back, view.dist)), fwd: fwd, right: right,
    up: cross(right, fwd)};
}

// Where the view may frame the scene, clear of the cards over the canvas: below both
// top cards, or below the header and left of the legend.
function freeBoxes(W, H) {
  function rect(id) {
    const e = document.getElementById(id);
    const r = e && e.getBoundingClientRect ? e.getBoundingClientRect() : null;
    return r && r.width > 0 ? r : {left: W, right: 0, top: 0, bottom: 0};
  }
  const head = rect("header"), legendBox = rect("legend"), help = rect("help");
  const bottom = Math.max(H * 0.6, Math.min(H - 16, help.top - 8));
  const boxes = [
    {x0: 16, x1: W - 16, y0: Math.max(head.bottom, legendBox.bottom) + 20, y1: bottom},
    {x0: 16, x1: Math.max(W * 0.5, legendBox.left - 8), y0: head.bottom + 20, y1: bottom},
  ];
  const usable = boxes.filter(function (b) { return b.x1 - b.x0 > 80 && b.y1 - b.y0 > 80; });
  return usable.length ? usable : [{x0: 0, x1: W, y0: 0, y1: H}];
}

// The projected bounds of ``points`` at the current view, or null when one is behind it.
function bounds(points, W, H) {
  const b = viewBasis(), F = 0.5 * H / Math.tan(FOV / 2);
  let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
  for (const p of points) {
    const d = sub(p, b.eye), z = dot(d, b.fwd);
    if (z < NEAR) return null;
    const x = W / 2 + F * dot(d, b.right) / z, y = H / 2 - F * dot(d, b.up) / z;
    x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
  }
  return {x0: x0, x1: x1, y0: y0, y1: y1};
}

// Frame ``points`` as large as the free boxes allow. In one box: aim at the centre of
// their bounding box, then alternately move the view back or forth until they just fit
// and pan (damped: near points move faster than far ones) towards centring them; the
// last step is a fit.
function fit(points) {
  const W = canvas.clientWidth || window.innerWidth, H = canvas.clientHeight || window.innerHeight;
  let best = null;
  for (const box of freeBoxes(W, H)) {
    fitIn(points, box, W, H);
    if (!best || view.dist < best.dist) best = {dist: view.dist, target: view.target};
  }
  view.dist = best.dist;
  view.target = best.target;
}

function fitIn(points, box, W, H) {
  let lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const p of points) {
    lo = lo.map(function (v, m) { return Math.min(v, p[m]); });
    hi = hi.map(function (v, m) { return Math.max(v, p[m]); });
  }
  view.target = mul(add(lo, hi), 0.5);
  function fitDistance() {
    let near = 5, far = 1e6;
    for (let it = 0; it < 50; it++) {
      view.dist = Math.sqrt(near * far);
      const b = bounds(points, W, H);
      if (b && b.x1 - b.x0 <= box.x1 - box.x0 && b.y1 - b.y0 <= box.y1 - box.y0) far = view.dist;
      else near = view.dist;
    }
    view.dist = far;
  }
  for (let round = 0; round < 6; round++) {
    fitDistance();
    const b = bounds(points, W, H);
    if (!b) break;
    const basis = viewBasis();
    const perPixel = 2 * view.dist * Math.tan(FOV / 2) / H;
    const dx = (b.x0 + b.x1) / 2 - (box.x0 + box.x1) / 2;
    const dy = (b.y0 + b.y1) / 2 - (box.y0 + box.y1) / 2;
    view.target = add(view.target, add(mul(basis.right, 0.5 * dx * perPixel),
      mul(basis.up, -0.5 * dy * perPixel)));
  }
  fitDistance();
}

function resetView(all) {
  view.target = centre.slice();
  const ref = S.cameras.find(function (c) { return c.reference; });
  if (ref) {
    // From across the assembly, a little to the side: the reference camera looks on
    // from behind it, and the logs it could not see face the viewer.
    const v = sub(ref.centre, centre);
    view.az = Math.atan2(v[0], v[2]) + Math.PI + 0.45;
    view.el = 0.62;
  } else {
    // Bare evidence: the grid's i to the right, k towards the viewer, from above.
    view.az = Math.atan2(G.i[0] + G.k[0], G.i[2] + G.k[2]) + 0.35;
    view.el = 0.6;
  }
  let points = boxCorners;
  if (all) {
    points = points.slice();
    for (const cam of S.cameras) points.push(cam.centre);
  }
  fit(points);
}

let drawn = [];       // {scr, owner, ghost} in painting order, for picking
let cameraMarks = []; // {x, y, index}
let frames = 0;

function frame() {
  const dpr = window.devicePixelRatio || 1;
  const W = canvas.clientWidth || window.innerWidth, H = canvas.clientHeight || window.innerHeight;
  if (canvas.width !== Math.round(W * dpr) || canvas.height !== Math.round(H * dpr)) {
    canvas.width = Math.round(W * dpr);
    canvas.height = Math.round(H * dpr);
  }
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const sky = ctx.createLinearGradient(0, 0, 0, H);
  sky.addColorStop(0, "#f5f7fa");
  sky.addColorStop(1, "#d9dfe7");
  ctx.fillStyle = sky;
  ctx.fillRect(0, 0, W, H);

  const basis = viewBasis();
  const eye = basis.eye, fwd = basis.fwd, right = basis.right, up = basis.up;
  const F = 0.5 * H / Math.tan(FOV / 2), cx = W / 2, cy = H / 2;
  const light = unit([0.35, 1.0, 0.25]);

  function toCam(p) { const d = sub(p, eye); return [dot(d, right), dot(d, up), dot(d, fwd)]; }
  function proj(c) { return [cx + F * c[0] / c[2], cy - F * c[1] / c[2]]; }
  function polyScreen(pts) {
    const cam = pts.map(toCam);
    let clipped = cam;
    if (cam.some(function (c) { return c[2] < NEAR; })) {
      clipped = [];
      for (let m = 0; m < cam.length; m++) {
        const p = cam[m], q = cam[(m + 1) % cam.length];
        const pin = p[2] >= NEAR, qin = q[2] >= NEAR;
        if (pin) clipped.push(p);
        if (pin !== qin) clipped.push(lerp(p, q, (NEAR - p[2]) / (q[2] - p[2])));
      }
      if (clipped.length < 3) return null;
    }
    return clipped.map(proj);
  }
  function lineScreen(a, b) {
    let p = toCam(a), q = toCam(b);
    if (p[2] < NEAR && q[2] < NEAR) return null;
    if (p[2] < NEAR) p = lerp(p, q, (NEAR - p[2]) / (q[2] - p[2]));
    if (q[2] < NEAR) q = lerp(q, p, (NEAR - q[2]) / (p[2] - q[2]));
    return [proj(p), proj(q)];
  }
  function path(scr) {
    ctx.beginPath();
    ctx.moveTo(scr[0][0], scr[0][1]);
    for (let m = 1; m < scr.length; m++) ctx.lineTo(scr[m][0], scr[m][1]);
    ctx.closePath();
  }
  function segment(a, b, colour, width) {
    const s = lineScreen(a, b);
    if (!s) return;
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.beginPath();
    ctx.moveTo(s[0][0], s[0][1]);
    ctx.lineTo(s[1][0], s[1][1]);
    ctx.stroke();
  }

  // The table and everything lying on it, under all else.
  let scr = polyScreen(tableCorners);
  if (scr) { path(scr); ctx.fillStyle = "#ece7dd"; ctx.fill(); }
  ctx.lineCap = "butt";
  for (const t of tableLines) segment(t[0], t[1], t[2] ? "rgba(90,80,60,0.16)"
    : "rgba(90,80,60,0.08)", 1);
  if (scr) { path(scr); ctx.strokeStyle = "rgba(90,80,60,0.35)"; ctx.lineWidth = 1; ctx.stroke(); }
  for (const l of G.lines) segment(l[0], l[1], "rgba(36,48,68,0.45)", 1);
  ctx.beginPath();
  for (const sh of shadows) {
    const s = polyScreen(sh);
    if (!s) continue;
    ctx.moveTo(s[0][0], s[0][1]);
    for (let m = 1; m < s.length; m++) ctx.lineTo(s[m][0], s[m][1]);
    ctx.closePath();
  }
  ctx.fillStyle = "rgba(40,35,25,0.16)";
  ctx.fill("nonzero");

  // Everything else, back to front.
  const items = [];
  function consider(face, ghost) {
    if (dot(sub(face.c, eye), face.n) >= 0) return;  // faces away
    items.push({face: face, ghost: ghost, depth: norm(sub(face.c, eye))});
  }
  for (const f of logFaces) consider(f, false);
  for (const f of ghostFaces) consider(f, true);
  for (const f of planes) items.push({plane: f, depth: norm(sub(f.c, eye))});
  for (const l of lines) items.push({line: l, depth: norm(sub(l.c, eye))});
  items.sort(function (p, q) { return q.depth - p.depth; });

  drawn = [];
  let faces = 0;
  ctx.lineJoin = "round";
  for (const it of items) {
    if (it.line) {
      const s = lineScreen(it.line.a, it.line.b);
      if (!s) continue;
      ctx.strokeStyle = it.line.style.colour;
      ctx.lineWidth = it.line.style.width;
      ctx.lineCap = "round";
      ctx.beginPath();
      ctx.moveTo(s[0][0], s[0][1]);
      ctx.lineTo(s[1][0], s[1][1]);
      ctx.stroke();
      continue;
    }
    if (it.plane) {
      const s = polyScreen(it.plane.pts);
      if (!s) continue;
      path(s);
      ctx.fillStyle = it.plane.fill;
      ctx.fill();
      continue;
    }
    const f = it.face;
    const s = polyScreen(f.pts);
    if (!s) continue;
    const lit = 0.42 + 0.45 * Math.max(0, dot(f.n, light)) + 0.25 * Math.max(0, -dot(f.n, fwd));
    path(s);
    faces += 1;
    if (it.ghost) {
      const isSel = selected && selected.type === "missed" && selected.index === f.owner.index;
      ctx.fillStyle = rgba(shadeColour(COL.missed, lit), isSel ? 0.55 : 0.26);
      ctx.fill();
    } else {
      const base = logColour(f.owner.index);
      const isSel = selected && selected.type === "log" && selected.index === f.owner.index;
      const c = shadeColour(isSel ? mix(base, [255, 255, 255], 0.45) : base, lit);
      ctx.fillStyle = rgba(c);
      ctx.strokeStyle = rgba(c);
      ctx.lineWidth = 0.7;
      ctx.fill();
      ctx.stroke();
    }
    drawn.push({scr: s, owner: f.owner, ghost: it.ghost});
  }

  // Overlays: the names of the grid frame's axes, the selected log's features, the
  // cameras' names.
  ctx.lineCap = "round";
  for (const ax of AXES) {
    const s = lineScreen(AXES_AT, ax.tip);
    if (s) label(ax.name, s[1][0] + 4, s[1][1] - 4, ax.colour, "bold 13px system-ui, sans-serif");
  }
  if (selected && selected.type === "log") {
    const feats = S.logs[selected.index].features;
    feats.forEach(function (ft, n) {
      const wide = n === hoverFeature;
      const pts = ft.shape;
      for (let m = 0; m + 1 < pts.length; m++) {
        segment(pts[m], pts[m + 1], wide ? "#000" : "rgba(255,255,255,0.9)", wide ? 8 : 6);
      }
      for (let m = 0; m + 1 < pts.length; m++) {
        segment(pts[m], pts[m + 1], rgba(evidenceColour(ft.p)), wide ? 5 : 3);
      }
    });
  }
  cameraMarks = [];
  S.cameras.forEach(function (cam, n) {
    const c = toCam(cam.centre);
    if (c[2] < NEAR) return;
    const p = proj(c);
    cameraMarks.push({x: p[0], y: p[1], index: n});
    ctx.fillStyle = cam.reference ? "#1c2533" : "#4e5f7c";
    ctx.beginPath();
    ctx.arc(p[0], p[1], 3.5, 0, 2 * Math.PI);
    ctx.fill();
    label(cam.label, p[0] + 7, p[1] - 6, "#1c2533", "12px system-ui, sans-serif");
  });

  drawPlan(W, H);
  frames += 1;
  statusEl.setAttribute("data-drawn", String(frames));
  statusEl.setAttribute("data-faces", String(faces));
}

// A plan of the table in a corner, turned with the view (its top is straight ahead):
// where the cameras stand around the assembly, even when they are out of the picture.
function drawPlan(W, H) {
  if (!S.cameras.length) return;
  const size = Math.min(190, 0.3 * Math.min(W, H));
  if (size < 90) return;
  // Bottom left, above the help line: the evidence panel opens on the right.
  const help = document.getElementById("help").getBoundingClientRect();
  const x0 = 12, y0 = Math.max(8, (help.height ? help.top : H) - size - 8);
  const fh = [-Math.sin(view.az), 0, -Math.cos(view.az)];
  const rh = [Math.cos(view.az), 0, -Math.sin(view.az)];
  const pts = boxCorners.slice();
  for (const cam of S.cameras) { pts.push(cam.centre); for (const q of cam.corners) pts.push(q); }
  let a0 = Infinity, a1 = -Infinity, b0 = Infinity, b1 = -Infinity;
  for (const p of pts) {
    const a = dot(p, rh), b = dot(p, fh);
    a0 = Math.min(a0, a); a1 = Math.max(a1, a); b0 = Math.min(b0, b); b1 = Math.max(b1, b);
  }
  const pad = 16, top = 16;
  const scale = Math.min((size - 2 * pad) / Math.max(a1 - a0, 1),
    (size - 2 * pad - top) / Math.max(b1 - b0, 1));
  const mx = x0 + size / 2, my = y0 + top + (size - top) / 2;
  function at(p) {
    return [mx + (dot(p, rh) - (a0 + a1) / 2) * scale, my - (dot(p, fh) - (b0 + b1) / 2) * scale];
  }
  function seg(p, q, colour, width) {
    const u = at(p), v = at(q);
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.beginPath();
    ctx.moveTo(u[0], u[1]);
    ctx.lineTo(v[0], v[1]);
    ctx.stroke();
  }
  ctx.save();
  ctx.fillStyle = "rgba(255,255,255,0.92)";
  ctx.strokeStyle = "rgba(20,30,50,0.15)";
  ctx.lineWidth = 1;
  ctx.beginPath();
  if (ctx.roundRect) ctx.roundRect(x0, y0, size, size, 8); else ctx.rect(x0, y0, size, size);
  ctx.fill();
  ctx.stroke();
  ctx.fillStyle = "#5a6577";
  ctx.font = "11px system-ui, sans-serif";
  ctx.fillText("plan · ahead ↑", x0 + 8, y0 + 14);
  ctx.lineCap = "round";
  for (const l of G.lines) seg(l[0], l[1], "rgba(36,48,68,0.3)", 1);
  const width = Math.max(1.5, 2 * R * scale);
  S.missed.forEach(function (log) {
    seg(log.axis[0], log.axis[1], rgba(COL.missed, 0.35), width);
  });
  S.logs.forEach(function (log, n) { seg(log.axis[0], log.axis[1], rgba(logColour(n)), width); });
  S.cameras.forEach(function (cam) {
    const colour = cam.reference ? "#1c2533" : "#4e5f7c";
    for (const q of cam.corners) seg(cam.centre, q, colour, 1);
    const c = at(cam.centre);
    ctx.fillStyle = colour;
    ctx.beginPath();
    ctx.arc(c[0], c[1], 3, 0, 2 * Math.PI);
    ctx.fill();
    ctx.font = "11px system-ui, sans-serif";
    const name = cam.label.replace(" (reference)", "");
    const tx = Math.min(Math.max(c[0] + 5, x0 + 4), x0 + size - ctx.measureText(name).width - 4);
    ctx.fillText(name, tx, Math.min(Math.max(c[1] - 5, y0 + 26), y0 + size - 4));
  });
  ctx.restore();
}

function label(text, x, y, colour, font) {
  ctx.font = font;
  ctx.lineWidth = 3;
  ctx.strokeStyle = "rgba(255,255,255,0.85)";
  ctx.strokeText(text, x, y);
  ctx.fillStyle = colour;
  ctx.fillText(text, x, y);
}

function logState(n) {
  const log = S.logs[n];
  if (mode === "truth" && log.correct !== null) return log.correct ? "right" : "wrong";
  if (log.seen === null) return "unknown";
  return log.seen ? "seen" : "inferred";
}
function logColour(n) { return COL[logState(n)]; }
function evidenceColour(p) {
  // Grey when not judged, towards green when the evidence says present, red absent.
  const t = Math.min(1, Math.abs(p - 0.5) * 2.2);
  if (Math.abs(p - 0.5) < 1e-9) return [150, 156, 168];
  return mix([190, 194, 200], p > 0.5 ? [30, 150, 50] : [205, 35, 35], t);
}

let pending = false;
function redraw() {
  if (pending) return;
  pending = true;
  window.requestAnimationFrame(function () { pending = false; frame(); });
}

// ---- the page around the canvas ---------------------------------------------------
function el(tag, attrs, children) {
  const e = document.createElement(tag);
  for (const key in attrs || {}) {
    if (key === "text") e.textContent = attrs[key];
    else if (key === "style") e.style.cssText = attrs[key];
    else e.setAttribute(key, attrs[key]);
  }
  for (const c of children || []) e.appendChild(typeof c === "string"
    ? document.createTextNode(c) : c);
  return e;
}
function swatch(c, cls) {
  return el("span", {class: "swatch" + (cls ? " " + cls : ""), style: "background:" + rgba(c)});
}

function header() {
  const box = document.getElementById("header-text");
  const s = S.summary;
  box.appendChild(el("h1", {text: "Estimate · " + S.title}));
  if (s.logs !== undefined) {
    const ex = s.extent.join(" × ");
    let text = s.logs + " logs on a " + ex + " grid";
    if (s.seen !== undefined) text += " · " + s.seen + " seen, " + (s.logs - s.seen)
      + " inferred";
    box.appendChild(el("div", {class: "line", text: text}));
  }
  const line = el("div", {class: "line"});
  line.appendChild(document.createTextNode("status " + s.status + " · log-probability "
    + fmt(s.log_probability, 2) + " · "));
  if (s.confident === null) {
    line.appendChild(document.createTextNode("confidence not tested"));
  } else {
    line.appendChild(el("span", {class: s.confident ? "good" : "bad",
      text: s.confident ? "confident" : "not confident"}));
    if (s.tolerance !== null) {
      line.appendChild(document.createTextNode(" (tolerance δ = " + fmt(s.tolerance, 3)
        + ", δ* = " + fmt(s.delta_star, 2) + ")"));
    }
  }
  box.appendChild(line);
  const views = s.views + (s.views === 1 ? " view" : " views");
  box.appendChild(el("div", {class: "line", text: s.pose
    ? "pose x = " + fmt(s.pose.x, 1) + " mm, z = " + fmt(s.pose.z, 1) + " mm, yaw = "
      + fmt(s.pose.yaw_deg, 2) + "° · " + views
    : "bare evidence (no pose): the grid frame is drawn at the table's origin"}));
  if (S.truth) {
    const t = S.truth;
    const l = el("div", {class: "line"});
    l.appendChild(document.createTextNode("against " + t.source + ": "));
    l.appendChild(el("span", {class: t.errors === 0 ? "good" : "bad",
      text: t.errors + (t.errors === 1 ? " error" : " errors")}));
    l.appendChild(document.createTextNode(" (paper's metric) · " + t.right + " right, "
      + t.wrong + " wrong, " + t.missed + " missed"));
    box.appendChild(l);
  }
  const notes = document.getElementById("notes");
  for (const n of S.notes) notes.appendChild(el("div", {text: "⚠ " + n}));
}

function legend() {
  const box = document.getElementById("legend");
  box.textContent = "";
  box.appendChild(el("h2", {text: "Logs"}));
  if (hasTruth) {
    const modes = el("div", {class: "modes"});
    for (const m of [["truth", "right / wrong"], ["evidence", "seen / inferred"]]) {
      const b = el("button", {class: mode === m[0] ? "on" : "", text: m[1]});
      b.addEventListener("click", function () {
        mode = m[0];
        legend();
        if (selected) panelFor(selected);
        redraw();
      });
      modes.appendChild(b);
    }
    box.appendChild(modes);
  }
  const counts = {};
  S.logs.forEach(function (log, n) { const k = logState(n); counts[k] = (counts[k] || 0) + 1; });
  const ul = el("ul");
  const keys = mode === "truth" ? ["right", "wrong"] : ["seen", "inferred", "unknown"];
  for (const k of keys) {
    if (k === "unknown" && !counts[k]) continue;
    ul.appendChild(el("li", {}, [swatch(COL[k]), LABEL[k],
      el("span", {class: "count", text: String(counts[k] || 0)})]));
  }
  if (hasTruth) {
    ul.appendChild(el("li", {}, [swatch(COL.missed, "ghost"), LABEL.missed,
      el("span", {class: "count", text: String(S.missed.length)})]));
  }
  if (S.cameras.length) {
    ul.appendChild(el("li", {}, [el("span", {class: "swatch line"}), "camera of a view",
      el("span", {class: "count", text: String(S.cameras.length)})]));
  }
  box.appendChild(ul);
  const explain = mode === "truth"
    ? "Right: the log matches the truth exactly; faint blue: truth logs the estimate missed."
    : "Seen: some view judged one of the log's own features. Inferred: the grammar put it "
      + "there without direct evidence.";
  box.appendChild(el("p", {class: "explain", text: explain + " Click a log for its evidence."}));
}

function panelFor(sel) {
  const panel = document.getElementById("panel");
  const body = document.getElementById("panel-body");
  body.textContent = "";
  hoverFeature = -1;
  if (!sel) { panel.classList.add("hidden"); return; }
  panel.classList.remove("hidden");
  placePanel();
  if (sel.type === "camera") {
    const cam = S.cameras[sel.index];
    body.appendChild(el("h2", {text: cam.label}));
    const rows = [["file", cam.source], ["image", cam.size[0] + " × " + cam.size[1] + " px"],
      ["centre", cam.centre.map(function (v) { return fmt(v, 0); }).join(", ") + " mm"]];
    if (cam.removed_from_layer !== null) {
      rows.push(["removed", "logs from layer " + cam.removed_from_layer + " up"]);
    }
    body.appendChild(kvTable(rows));
    return;
  }
  if (sel.type === "missed") {
    const log = S.missed[sel.index];
    body.appendChild(el("h2", {}, [swatch(COL.missed, "ghost"), "Truth log " + log.id]));
    body.appendChild(el("p", {}, [badge("missed", COL.missed)]));
    body.appendChild(kvTable([["notches", String(log.notches)],
      ["layer", log.layer + " (runs along " + (log.layer % 2 === 0 ? "i" : "k") + ")"],
      ["notch 0 at", "i = " + log.at[0] + ", k = " + log.at[1] + " (truth's grid)"]]));
    body.appendChild(el("p", {class: "explain", text: "A log of the truth that no estimated "
      + "log matches exactly."}));
    return;
  }
  const log = S.logs[sel.index];
  body.appendChild(el("h2", {}, [swatch(logColour(sel.index)), "Log " + log.id]));
  const badges = el("p");
  if (log.seen !== null) {
    badges.appendChild(badge(log.seen ? "seen" : "inferred", log.seen ? COL.seen : COL.inferred));
  }
  if (log.correct !== null) {
    badges.appendChild(badge(log.correct ? "right" : "wrong",
      log.correct ? COL.right : COL.wrong));
  }
  body.appendChild(badges);
  body.appendChild(kvTable([
    ["notches", String(log.notches)],
    ["layer", log.layer + " (runs along " + (log.layer % 2 === 0 ? "i" : "k") + ")"],
    ["notch 0 at", "i = " + log.at[0] + ", k = " + log.at[1]],
    ["positions", log.positions.map(function (q) { return "(" + q.join(", ") + ")"; })
      .join(" ")],
  ]));
  if (log.seen !== null) {
    body.appendChild(el("p", {class: "explain", text: log.seen
      ? "Seen: a view judged at least one of its features."
      : "Inferred: no view judged any of its features; the grammar put it here."}));
  }
  body.appendChild(el("h3", {text: "Its features (reference view)"}));
  if (!log.features.length) {
    body.appendChild(el("p", {class: "explain", text: "The estimate file lists no features."}));
    return;
  }
  const hasVisible = log.features.some(function (f) { return f.visible !== null; });
  const head = ["", "kind", "at", "p", "value"].concat(hasVisible ? ["visible"] : []);
  const table = el("table", {class: "features"});
  table.appendChild(el("thead", {}, [el("tr", {}, head.map(function (h) {
    return el("th", {text: h});
  }))]));
  const tbody = el("tbody");
  log.features.forEach(function (f, n) {
    const judged = Math.abs(f.p - 0.5) > 1e-9;
    const cells = [
      el("td", {}, [el("span", {class: "dot", style: "background:" + rgba(evidenceColour(f.p))})]),
      el("td", {text: f.kind, title: KIND_TEXT[f.kind] || ""}),
      el("td", {text: "(" + f.at.join(", ") + ")"}),
      el("td", {text: judged ? fmt(f.p, 2) : "½"}),
      el("td", {text: f.value ? "present" : "absent"}),
    ];
    if (hasVisible) {
      cells.push(el("td", {text: f.visible === null ? "–" : (f.visible ? "yes" : "no")}));
    }
    const tr = el("tr", {class: judged ? "judged" : "unjudged"}, cells);
    tr.addEventListener("mouseenter", function () { hoverFeature = n; redraw(); });
    tr.addEventListener("mouseleave", function () { hoverFeature = -1; redraw(); });
    tbody.appendChild(tr);
  });
  table.appendChild(tbody);
  body.appendChild(table);
  body.appendChild(el("p", {class: "explain", text: "p: the reference view's evidence that "
    + "the feature is present (½: not judged: occluded or outside the image). Value: the "
    + "feature under the estimate. Ends: the log's end discs; u, v, w: stretches of the "
    + "bottom edge before, after and between its notches. Drawn on the logs in the dot's "
    + "colour: green present, red absent, grey not judged."}));
}
// Below the legend, whose height depends on the mode and the fonts.
function placePanel() {
  const panel = document.getElementById("panel");
  const top = document.getElementById("legend").getBoundingClientRect().bottom + 10;
  panel.style.top = top + "px";
  panel.style.maxHeight = "calc(100% - " + (top + 44) + "px)";
}
function badge(text, colour) {
  return el("span", {class: "badge", style: "background:" + rgba(colour), text: text});
}
function kvTable(rows) {
  return el("table", {class: "kv"}, rows.map(function (r) {
    return el("tr", {}, [el("td", {text: r[0]}), el("td", {text: r[1]})]);
  }));
}

function select(sel) {
  selected = sel;
  panelFor(sel);
  statusEl.setAttribute("data-selected", sel ? sel.type + ":" + sel.index : "");
  redraw();
}

// ---- picking and the mouse --------------------------------------------------------
function inside(pt, poly) {
  let hit = false;
  for (let m = 0, n = poly.length - 1; m < poly.length; n = m++) {
    const a = poly[m], b = poly[n];
    if ((a[1] > pt[1]) !== (b[1] > pt[1])
      && pt[0] < (b[0] - a[0]) * (pt[1] - a[1]) / (b[1] - a[1]) + a[0]) hit = !hit;
  }
  return hit;
}
function pick(x, y) {
  for (const c of cameraMarks) {
    if (Math.hypot(c.x - x, c.y - y) < 9) return {type: "camera", index: c.index};
  }
  for (const ghostPass of [false, true]) {
    for (let m = drawn.length - 1; m >= 0; m--) {
      const d = drawn[m];
      if (d.ghost === ghostPass && inside([x, y], d.scr)) return d.owner;
    }
  }
  return null;
}

let drag = null;
let moved = false;                 // the user has moved the view
let fitAll = /view=all/.test(window.location.hash);
canvas.addEventListener("pointerdown", function (e) {
  drag = {x: e.clientX, y: e.clientY, moved: 0, pan: e.shiftKey || e.button === 2};
  if (canvas.setPointerCapture && e.pointerId !== undefined) {
    try { canvas.setPointerCapture(e.pointerId); } catch (err) { /* synthetic event */ }
  }
  canvas.classList.add("dragging");
});
canvas.addEventListener("pointermove", function (e) {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  drag.moved += Math.abs(dx) + Math.abs(dy);
  moved = true;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.pan) {
    const H = canvas.clientHeight || 1;
    const perPixel = 2 * view.dist * Math.tan(FOV / 2) / H;
    const b = viewBasis();
    view.target = add(view.target, add(mul(b.right, -dx * perPixel), mul(b.up, dy * perPixel)));
  } else {
    view.az -= dx * 0.008;
    view.el = Math.min(1.55, Math.max(0.03, view.el + dy * 0.008));
  }
  redraw();
});
canvas.addEventListener("pointerup", function (e) {
  canvas.classList.remove("dragging");
  if (drag && drag.moved < 4) {
    const box = canvas.getBoundingClientRect();
    select(pick(e.clientX - box.left, e.clientY - box.top));
  }
  drag = null;
});
canvas.addEventListener("pointercancel", function () {
  drag = null;
  canvas.classList.remove("dragging");
});
canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
canvas.addEventListener("wheel", function (e) {
  e.preventDefault();
  view.dist = Math.min(2e5, Math.max(20, view.dist * Math.exp(e.deltaY * 0.0012)));
  moved = true;
  redraw();
}, {passive: false});
canvas.addEventListener("dblclick", function () {
  moved = false;
  resetView(fitAll);
  redraw();
});
function resized() {
  // Until the user moves the view, keep it framed for the window's new shape. Drawn at
  // once, not on the next animation frame: a headless browser may take its screenshot
  // right after resizing the window.
  if (!moved) resetView(fitAll);
  if (selected) placePanel();
  frame();
}
window.addEventListener("resize", resized);
if (window.ResizeObserver) {
  let lastSize = "";
  new ResizeObserver(function () {
    const size = canvas.clientWidth + "x" + canvas.clientHeight;
    if (size !== lastSize) { lastSize = size; resized(); }
  }).observe(canvas);
}
document.getElementById("close").addEventListener("click", function () { select(null); });
window.addEventListener("keydown", function (e) {
  if (e.key === "Escape") select(null);
  if (e.key === "f" || e.key === "a") {
    fitAll = e.key === "a";
    moved = false;
    resetView(fitAll);
    redraw();
  }
});

// ---- start ----------------------------------------------------------------------------
header();
legend();
resetView(fitAll);
frame();
statusEl.setAttribute("data-logs", String(S.logs.length));
statusEl.setAttribute("data-cameras", String(S.cameras.length));
statusEl.setAttribute("data-notes", String(S.notes.length));
const hash = window.location.hash;
const wanted = /log=(\d+)/.exec(hash);
if (wanted && Number(wanted[1]) < S.logs.length) {
  select({type: "log", index: Number(wanted[1])});
  frame();
}
if (/selftest/.test(hash)) {
  // Click the centre of the front-most painted log face, as a user would.
  let target = null;
  for (let m = drawn.length - 1; m >= 0 && !target; m--) {
    if (!drawn[m].ghost && drawn[m].owner.type === "log") target = drawn[m];
  }
  if (!target) {
    statusEl.setAttribute("data-selftest", "no log drawn");
  } else {
    let x = 0, y = 0;
    for (const p of target.scr) { x += p[0]; y += p[1]; }
    x /= target.scr.length;
    y /= target.scr.length;
    const box = canvas.getBoundingClientRect();
    const opts = {clientX: box.left + x, clientY: box.top + y, bubbles: true, button: 0};
    canvas.dispatchEvent(new PointerEvent("pointerdown", opts));
    canvas.dispatchEvent(new PointerEvent("pointerup", opts));
    frame();
    const shown = document.querySelector("#panel-body h2");
    const want = "log:" + target.owner.index;
    const got = statusEl.getAttribute("data-selected");
    const outcome = [got === want && shown
      ? "ok " + want + " " + shown.textContent : "picked " + got + ", wanted " + want];
    // A drag turns the view and keeps the selection; the wheel moves the view back.
    const az = view.az, dist = view.dist;
    const at = function (dx) {
      return {clientX: opts.clientX + dx, clientY: opts.clientY, bubbles: true, button: 0};
    };
    canvas.dispatchEvent(new PointerEvent("pointerdown", at(0)));
    canvas.dispatchEvent(new PointerEvent("pointermove", at(60)));
    canvas.dispatchEvent(new PointerEvent("pointerup", at(60)));
    const kept = statusEl.getAttribute("data-selected") === want;
    outcome.push(view.az !== az && kept ? "orbit ok" : "orbit failed");
    canvas.dispatchEvent(new WheelEvent("wheel", {deltaY: 200, bubbles: true,
      cancelable: true}));
    outcome.push(view.dist > dist ? "zoom ok" : "zoom failed");
    frame();
    statusEl.setAttribute("data-selftest", outcome.join(" | "));
  }
}
})();
"""

PAGE_TEMPLATE = (
    "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
    "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    "<title>@TITLE@</title>\n<style>" + _STYLE + "</style>\n</head>\n<body>\n"
    "<canvas id=\"view\"></canvas>\n"
    "<div id=\"header\" class=\"card\"><div id=\"header-text\"></div>"
    "<div id=\"notes\"></div></div>\n"
    "<div id=\"legend\" class=\"card\"></div>\n"
    "<div id=\"panel\" class=\"card hidden\"><button id=\"close\" class=\"close\" "
    "title=\"close (Esc)\">×</button><div id=\"panel-body\"></div></div>\n"
    "<div id=\"help\">drag: orbit · shift- or right-drag: pan · wheel: zoom · click a log: "
    "its evidence · double-click: reset · f / a: fit assembly / all</div>\n"
    "<div id=\"status\" hidden data-drawn=\"0\" data-errors=\"\"></div>\n"
    "<script>" + _ERROR_TRAP + "</script>\n"
    "<script type=\"application/json\" id=\"scene-data\">@SCENE@</script>\n"
    "<script>" + _SCRIPT + "</script>\n</body>\n</html>\n"
)
