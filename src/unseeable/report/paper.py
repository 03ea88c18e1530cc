"""The report of a reproduction: every table and figure beside the paper's number.

:func:`write_report` writes, from a :class:`~unseeable.evaluate.reproduce.Reproduction`,

* ``report.md``: Markdown, its figures linked (``figures/*.png``);
* ``report.html``: the same report as one self-contained page (figures embedded as
  base64 PNG, the showcase's 3-D page inline; nothing is fetched from a network);
* ``report.json``: the settings, code version, machine, stage times and every table
  (``unseeable/reproduction@1``).

Both documents come from one list of blocks (headings, paragraphs, quotes, tables,
figures), so they say the same. The paper's published numbers are quoted verbatim
(:data:`PAPER_CLAIMS`, from the paper's LaTeX source with ``~`` read as a space) and
summarised in :data:`PAPER_NUMBERS`.
"""

from __future__ import annotations

import base64
import html
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from unseeable.fileio import atomic_write_bytes, write_json

# A run is an unseeable.evaluate.reproduce.Reproduction, which imports this module: it is
# read by its attributes only (typed Any here, so that the report does not import back).
Reproduction = Any

__all__ = ["PAPER_TITLE", "PaperClaim", "PAPER_CLAIMS", "PAPER_NUMBERS", "BOUND",
           "report_blocks", "report_markdown", "report_html", "write_report", "within",
           "publish_report", "PUBLISHED_WIDTH"]

PAPER_TITLE = "Seeing Unseeability to See the Unseeable"

#: The paper's bound on errors per image (Fig. visibility).
BOUND = 12


@dataclass(frozen=True)
class PaperClaim:
    """A sentence of the paper, verbatim (``~`` read as a space, ``\\%`` as ``%``,
    ``\\emph{x}`` as ``x``), and where it stands."""

    where: str
    quote: str


#: The paper's sentences that carry its published results.
PAPER_CLAIMS: dict[str, PaperClaim] = {
    "corpus": PaperClaim("§ Results", "We gathered a corpus of 5 different images of each of "
                         "32 different structures, each from a different viewpoint, for a "
                         "total of 160 images."),
    "visibility_images": PaperClaim("§ Results", "We performed combined visibility and "
                                    "structure estimation on 105 of the 160 images"),
    "visibility": PaperClaim("Fig. visibility", "100% of the structures estimated had 12 or "
                             "fewer errors."),
    "visibility_same": PaperClaim("Fig. visibility", "Note that the latter performs as well "
                                  "as the former."),
    "delta_star": PaperClaim("§ Structure-Estimation Confidence",
                             "We have determined empirically that setting "
                             "$\\delta^*=0.2$ yields a good tradeoff: only 3/105 false "
                             "positives and 7/105 false negatives on our corpus."),
    "confidence": PaperClaim("§ Results", "This resulted in only 3 false positives and 7 "
                             "false negatives on our corpus."),
    "active_images": PaperClaim("§ Results", "We then evaluated the active-vision process for "
                                "performing actions to improve structure-estimation "
                                "confidence on 90 images from our corpus."),
    "active": PaperClaim("§ Results", "Note that our active-vision processes consistently "
                         "reduce estimation error."),
    "language_sentence": PaperClaim("§ Results", "The user provides the sentence window left "
                                    "of and perpendicular to door."),
    "language": PaperClaim("§ Results, Fig. language", "Yet this sentence together with the "
                           "single image from the first view is sufficient to correctly "
                           "estimate the structure"),
}

#: The paper's published numbers (§ Confidence and § Results).
PAPER_NUMBERS: dict[str, Any] = {
    "structures": 32, "views_per_structure": 5, "images": 160,
    "visibility_images": 105, "within_bound": 1.0, "bound": BOUND,
    "confidence_images": 105, "false_positives": 3, "false_negatives": 7, "delta_star": 0.2,
    "active_images": 90,
}


# ---- blocks -------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Heading:
    level: int
    text: str


@dataclass(frozen=True)
class _Text:
    text: str  # inline: **bold**, `code`, [text](link)


@dataclass(frozen=True)
class _Quote:
    text: str


@dataclass(frozen=True)
class _Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


@dataclass(frozen=True)
class _Figure:
    path: str  # relative to the report folder
    caption: str


@dataclass(frozen=True)
class _Page:
    path: str  # a 3-D page, relative to the report folder
    caption: str


def within(histogram: list[float], bound: int = BOUND) -> float:
    """Share of images with at most ``bound`` errors, from an error histogram (share with
    at most t errors for t = 0, 1, …, its last entry the largest count seen).

    Examples
    --------
    >>> within([0.5, 0.75, 1.0])
    1.0
    >>> within([0.25] * 13 + [1.0])
    0.25
    """
    return float(histogram[min(bound, len(histogram) - 1)])


def _n(x: Any, digits: int = 2) -> str:
    if x is None:
        return "–"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    return f"{x:.{digits}f}"


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def _count(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, in the plural unless ``n`` is 1."""
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"


def _seconds(s: float) -> str:
    if s < 60:
        return f"{s:.1f} s"
    m, s = divmod(round(s), 60)
    if m < 60:
        return f"{m} min {s:02d} s"
    h, m = divmod(m, 60)
    return f"{h} h {m:02d} min"


def _claim(key: str) -> _Quote:
    c = PAPER_CLAIMS[key]
    text = c.quote.replace("$\\delta^*=0.2$", "δ* = 0.2")
    return _Quote(f"Paper ({c.where}): “{text}”")


def _failed(table: dict, what: str) -> list:
    failed = table.get("failed") or []
    if not failed:
        return []
    shown = "; ".join(f"{f['name']} at {f.get('angle', f.get('start'))}°: {f['error']}"
                      for f in failed[:5])
    more = f" (and {len(failed) - 5} more)" if len(failed) > 5 else ""
    return [_Text(f"{_count(len(failed), what[:-1], what)} failed: {shown}{more}.")]


def _figure(stage, name: str, caption: str) -> list:
    path = f"figures/{name}"
    return [_Figure(path, caption)] if path in stage.figures else []


def _note(stage) -> list:
    return [_Text(f"*{stage.note}*")] if stage.note else []


def _settings_rows(rep: Reproduction) -> list[tuple[str, str]]:
    s = rep.settings
    corpus = rep.stage("corpus").tables.get("corpus", {})
    designs = "all 32 designs" if s.designs is None else ", ".join(s.designs)
    return [
        ("run", f"{s.name}" + (" (a small subset of the paper's corpus and protocol)"
                               if s.name == "quick" else "")),
        ("corpus", f"{designs}: {corpus.get('structures', '–')} structures × "
                   f"{len(s.angles)} stations ({', '.join(f'{a:g}°' for a in s.angles)}) = "
                   f"{corpus.get('views', '–')} images"),
        ("rendering", f"{s.size[0]}×{s.size[1]}, {s.spp} samples per pixel, seed {s.seed}"
                      + (", randomised looks" if s.randomise else "")),
        ("pose", "known (the views' recorded poses)" if s.known_pose
         else "estimated from each image"),
        ("estimator", f"prior {s.prior}, backend {s.backend}, {s.time_limit:g} s per solve"),
        ("several views", "every starting station" if s.view_starts is None
         else f"{s.view_starts} starting station{'s' * (s.view_starts != 1)} per structure "
              "(seeded)"),
        ("active vision", "every starting station" if s.starts is None
         else f"{s.starts} starting station{'s' * (s.starts != 1)} per structure (seeded)"),
        ("active vision", f"at most {s.max_actions} actions; robot "
                          + (f"on every design from {s.robot_start:g}°" if s.robot
                             else "not run")),
        ("folders", f"corpus `{rep.corpus}`, records `{rep.results}`"),
        ("executor", rep.executor),
    ]


def _version_text(v: dict) -> str:
    text = f"unseeable {v.get('package')}"
    if v.get("describe"):
        text += f", git {v['describe']}"
        if v.get("commit"):
            text += f" (commit {v['commit']})"
    else:
        text += " (no git checkout found)"
    return text


def _machine_text(m: dict) -> str:
    cpus = m.get("cpus")
    usable = m.get("usable_cpus")
    text = f"{cpus} CPUs" + (f" ({usable} usable)" if usable and usable != cpus else "")
    text += f", {m.get('processor')}, {m.get('platform')}, Python {m.get('python')}"
    loads = [(w, m.get(k)) for w, k in (("start", "load_start"), ("end", "load_end"))]
    loads = [(w, x) for w, x in loads if x]
    if loads:
        text += "; load average (1, 5, 15 min) " + ", ".join(
            f"{' / '.join(f'{v:.1f}' for v in x)} at the {w}" for w, x in loads)
    return text


def _stage_work(stage) -> str:
    t = stage.tables
    if stage.name == "corpus" and "corpus" in t:
        c = t["corpus"]
        return (f"{c['views']} views: {c['rendered']} rendered "
                f"({_seconds(c['render_seconds'])} of rendering), {c['cached']} cached")
    if stage.name in ("visibility", "confidence"):
        return f"{_count(stage.jobs, 'image')} (one set of records)"
    if stage.name == "views":
        return _count(stage.jobs, "structure × start job")
    if stage.name == "active" and "active" in t:
        robot = t["active"].get("robot")
        return (_count(t["active"]["images"], "starting image")
                + (f", {_count(robot['structures'], 'robot run')}" if robot else ""))
    if stage.name == "language":
        return _count(stage.jobs, "image") + (", Fig. language" if "language-figure" in t
                                              else "")
    if stage.name == "showcase" and "showcase" in t:
        s = t["showcase"]
        return f"{s['name']} at {s['angle']:g}°"
    return stage.note or ""


def _headline(rep: Reproduction) -> _Table:
    rows = []
    corpus = rep.stage("corpus").tables.get("corpus")
    if corpus:
        rows.append(("corpus", "32 structures × 5 views = 160 images",
                     f"{corpus['structures']} structures × {len(rep.settings.angles)} views "
                     f"= {corpus['views']} images"))
    vis = rep.stage("visibility").tables.get("visibility")
    if vis:
        rows.append((f"images within {BOUND} errors, automatic visibility",
                     "100 % (105 images)",
                     f"{_pct(within(vis['automatic']))} ({_count(vis['evaluated'], 'image')})"))
        rows.append(("mean errors, automatic / manual visibility",
                     "“the latter performs as well as the former”",
                     f"{vis['mean_errors_automatic']:.2f} / {vis['mean_errors_manual']:.2f}"))
    conf = rep.stage("confidence").tables.get("confidence")
    if conf:
        rows.append(("δ* = 0.2: false positives / false negatives", "3 / 7 of 105",
                     f"{conf['false_positives']} / {conf['false_negatives']} of "
                     f"{conf['images']}"))
        shipped = conf.get("with_readings")
        if shipped is not None and conf.get("reading_shift") is not None:
            rows.append((f"with the reading test (s* = {conf['reading_shift']:g}): false "
                         "positives / false negatives", "–",
                         f"{shipped['false_positives']} / {shipped['false_negatives']} of "
                         f"{conf['images']}"))
    views = rep.stage("views").tables.get("views")
    if views:
        means = views["mean_errors"]
        rows.append(("mean errors with 1, 2, … views", "– (no figure)",
                     " / ".join(f"{means[n]:.2f}" for n in means)))
    active = rep.stage("active").tables.get("active")
    if active:
        m = active["mean_errors"]
        rows.append(("active vision: mean errors, baseline → views / disassembly / combined",
                     "“consistently reduce estimation error” (90 images)",
                     f"{m['baseline']:.2f} → {m['views']:.2f} / {m['disassembly']:.2f} / "
                     f"{m['combined']:.2f} ({_count(active['images'], 'image')})"))
        robot = active.get("robot")
        if robot and robot.get("mean_errors_end") is not None:
            rows.append(("robot's closed loop: confident (wrong), mean errors start → end",
                         "–", f"{robot['confident']} of {robot['structures']} "
                         f"({robot['confident_wrong']}); "
                         f"{robot['mean_errors_start']:.2f} → {robot['mean_errors_end']:.2f}"))
    lang = rep.stage("language").tables
    if "language" in lang:
        t = lang["language"]
        rows.append(("language: mean errors, image alone → with its description", "–",
                     f"{t['mean_errors_without']:.2f} → {t['mean_errors_with']:.2f} "
                     f"({_count(t['evaluated'], 'image')})"))
    if "language-figure" in lang:
        panels = lang["language-figure"]["panels"]
        rows.append(("Fig. language: errors of (a) view 1, (b) view 2, (c) both, "
                     "(d) view 1 + a sentence", "(d) correct",
                     " / ".join(str(p["errors"]) for p in panels)))
    return _Table(("measure", "paper", "this run"), tuple(rows))


def report_blocks(rep: Reproduction) -> list:
    """The report as blocks (see :func:`report_markdown`, :func:`report_html`)."""
    blocks: list = [_Heading(1, f"Reproducing “{PAPER_TITLE}”")]
    kind = ("a **quick** run: a small subset of the corpus and the protocol, to check that "
            "every stage runs; its numbers are not the paper's experiment"
            if rep.settings.name == "quick" else f"a **{rep.settings.name}** run")
    blocks.append(_Text(
        f"Written by `unseeable reproduce` on {rep.started} (UTC): {kind}. Total wall time "
        f"{_seconds(rep.seconds)}. Each table below is the one the experiment's command "
        "(`unseeable experiment …`) prints for the same records; the paper's published "
        "numbers stand beside it, quoted from its text. Each photograph's pose is searched "
        "once, by the first stage that estimates it, and read back by the others "
        "(`results/pose-searches`): the estimates are the same, but the later stages' "
        "seconds per estimate leave the search out (the visibility stage's include it)."))
    blocks += [_Heading(2, "Headline"), _headline(rep)]

    blocks.append(_Heading(2, "Run"))
    blocks.append(_Table(("setting", "value"), tuple(_settings_rows(rep))))
    blocks.append(_Table(("", ""), (("code", _version_text(rep.version)),
                                    ("machine", _machine_text(rep.machine)))))
    blocks.append(_Heading(3, "Stage times"))
    rows = [(s.title, _seconds(s.seconds), _stage_work(s)) for s in rep.stages]
    rows.append(("**total**", f"**{_seconds(rep.seconds)}**", ""))
    blocks.append(_Table(("stage", "wall time", "work"), tuple(rows)))

    # Visibility
    st = rep.stage("visibility")
    blocks += [_Heading(2, "Visibility: manual vs automatic"), _claim("visibility_images"),
               _claim("visibility"), _claim("visibility_same")]
    vis = st.tables.get("visibility")
    if vis:
        blocks += _figure(st, "visibility.png", "Error histograms: share of images with at "
                          "most t errors, manual (ground-truth) and automatic visibility.")
        n = vis["evaluated"]
        kinds = vis["errors_by_kind"]
        blocks.append(_Table(("", "paper", "automatic visibility", "manual visibility"), (
            ("images evaluated", "105 of 160", f"{n} of {vis['images']}", f"{n}"),
            (f"within {BOUND} errors", "100 %",
             f"{_pct(within(vis['automatic']))}", f"{_pct(within(vis['manual']))}"),
            ("mean errors", "–", f"{vis['mean_errors_automatic']:.2f}",
             f"{vis['mean_errors_manual']:.2f}"),
            ("exact", "–", _pct(vis["exact_automatic"]), _pct(vis["exact_manual"])),
            ("largest", "–", str(vis["max_errors_automatic"]), "–"),
            ("errors by kind: split / extra / missing / mixed", "–",
             " / ".join(str(kinds["automatic"][k]) for k in kinds["automatic"]),
             " / ".join(str(kinds["manual"][k]) for k in kinds["manual"])),
        )))
        blocks.append(_Text(
            f"The visibility fixpoint took {vis['mean_iterations']:.2f} estimates per image on "
            f"average ({vis['cycles']} cycles); its visibility agrees with the truth's on "
            f"{vis['mean_visibility_agreement']:.1%} of the features. Median time per image "
            f"{vis['median_seconds']:.2f} s."))
        blocks += _failed(vis, "images")
    blocks += _note(st)

    # Confidence
    st = rep.stage("confidence")
    blocks += [_Heading(2, "Confidence (δ* = 0.2)"), _claim("delta_star"), _claim("confidence")]
    conf = st.tables.get("confidence")
    if conf:
        blocks += _figure(st, "confidence.png", "Estimation tolerance δ of right and wrong "
                          "estimates, and the threshold δ*.")
        rows = [
            ("images", "105", str(conf["images"])),
            ("false positives (confident, wrong)", "3", str(conf["false_positives"])),
            ("false negatives (not confident, right)", "7",
             f"{conf['false_negatives']} "
             f"({_count(conf['false_negatives_exact_ties'], 'exact tie')})"),
            ("right estimates / confident", "–", f"{conf['correct']} / {conf['confident']}"),
        ]
        shipped = conf.get("with_readings")
        if shipped is not None and conf.get("reading_shift") is not None:
            rows.append((f"with the reading test (s* = {conf['reading_shift']:g}): false "
                         "positives / negatives", "–",
                         f"{shipped['false_positives']} / {shipped['false_negatives']} "
                         f"({shipped['confident']} confident)"))
        blocks.append(_Table(("", "paper", "this run"), tuple(rows)))
        blocks.append(_Text("The first rows are the paper's δ* test. An exact tie has "
                            "tolerance 0: another structure is exactly as probable, so no "
                            "threshold could call the estimate confident. The shipped "
                            "confidence adds the reading test: the estimate must also stay "
                            "the MAP when every seen feature's reading is worth up to s* "
                            "log-odds less (docs/decisions.md)."))
    blocks += _note(st)

    # Views
    st = rep.stage("views")
    blocks.append(_Heading(2, "Several views and partial disassembly"))
    blocks.append(_Text("The paper combines several views and disassembly in its active-vision "
                        "experiment and publishes no figure of its own for them."))
    views = st.tables.get("views")
    if views:
        blocks += _figure(st, "views.png", "Errors with 1, 2, … views of each structure.")
        ns = list(views["mean_errors"])
        blocks.append(_Table(("views", *ns), (
            ("mean errors", *(f"{views['mean_errors'][n]:.2f}" for n in ns)),
            ("largest", *(str(views["max_errors"][n]) for n in ns)),
            ("confident and wrong", *(str(views["confident_wrong"][n]) for n in ns)),
            ("median seconds", *(f"{views['median_seconds'][n]:.1f}" for n in ns)),
        )))
        structures = views["errors_all_views_by_structure"]
        text = (f"With all views, {views['structures_within_2_all_views']} of "
                f"{len(structures)} structures are within 2 errors.")
        d = views["disassembly"]
        if d["pairs"]:
            text += (f" {_count(d['pairs'], 'disassembly pair')} (a full view and the same "
                     "station's "
                     f"view after the arm removed the upper layers): mean errors "
                     f"{d['mean_errors_single']:.2f} alone → {d['mean_errors_pair']:.2f} "
                     f"with the pair; hidden logs right {d['hidden_right_single']} → "
                     f"{d['hidden_right_pair']} of {d['hidden_logs']}.")
        blocks.append(_Text(text))
        blocks += _failed(views, "jobs")
    blocks += _note(st)

    # Active vision
    st = rep.stage("active")
    blocks += [_Heading(2, "Active vision"), _claim("active_images"), _claim("active")]
    active = st.tables.get("active")
    if active:
        blocks += _figure(st, "active.png", "Fig. active: errors at termination of the "
                          "baseline (one view) and each active-vision process.")
        keys = ("baseline", "disassembly", "views", "combined")
        blocks.append(_Table(
            ("process", "mean errors", "largest", "confident", "confident and wrong",
             "actions per image"),
            tuple((k, f"{active['mean_errors'][k]:.2f}", str(active["max_errors"][k]),
                   str(active["confident"][k]), str(active["confident_wrong"][k]),
                   "–" if k == "baseline" else f"{active['actions_per_image'][k]:.2f}")
                  for k in keys)))
        blocks.append(_Text(
            f"{_count(active['images'], 'starting image')} of "
            f"{_count(active['structures'], 'structure')} (the paper: 90 images); combined, "
            f"{active['combined_structures_within_2']} of "
            f"{active['structures']} structures within 2 errors from every start."))
        fig = active.get("results_figure")
        if fig:
            blocks += _figure(st, "results.png",
                              f"Fig. results: {fig['name']} from {fig['start']:g}°, the "
                              "baseline's and each process's final estimate, green right "
                              "and red wrong.")
        robot = active.get("robot")
        if robot:
            blocks.append(_Heading(3, "The robot's closed loop"))
            rows = tuple((name, str(r["errors_start"]), str(r["errors"]), str(r["actions"]),
                          _n(r["confident"]), r["stopped"])
                         for name, r in robot["by_structure"].items())
            blocks.append(_Table(("structure", "errors at the start", "at the end", "actions",
                                  "confident", "stopped"), rows))
            if robot.get("mean_errors_end") is not None:
                blocks.append(_Text(
                    f"{robot['confident']} of {robot['structures']} structures confident "
                    f"({robot['confident_wrong']} wrong); mean errors "
                    f"{robot['mean_errors_start']:.2f} → {robot['mean_errors_end']:.2f} in "
                    f"{robot['mean_actions']:.2f} actions."))
            blocks += _failed({"failed": [{**f, "angle": rep.settings.robot_start}
                                          for f in robot["failed"]]}, "robot runs")
        blocks += _failed(active, "starting images")
    blocks += _note(st)

    # Language
    st = rep.stage("language")
    blocks += [_Heading(2, "Language"), _claim("language_sentence"), _claim("language")]
    lang = st.tables.get("language")
    if lang:
        blocks += _figure(st, "language.png", "Errors of each image alone and with its true "
                          "description.")
        blocks.append(_Table(("", "image alone", "with its true description"), (
            ("mean errors", f"{lang['mean_errors_without']:.2f}",
             f"{lang['mean_errors_with']:.2f}"),
            ("exact", str(lang["exact_without"]), str(lang["exact_with"])),
            ("median seconds", f"{lang['median_seconds_without']:.1f}",
             f"{lang['median_seconds_with']:.1f}"),
        )))
        blocks.append(_Text(f"{lang['evaluated']} images of structures with a door or a "
                            f"window: better {lang['better']}, same {lang['same']}, worse "
                            f"{len(lang['worse'])}."))
        blocks += _failed(lang, "images")
    demo = st.tables.get("language-figure")
    if demo:
        blocks += _figure(st, "language-figure.png",
                          f"Fig. language: {demo['structure']}, views {demo['view1']:g}° and "
                          f"{demo['view2']:g}°, sentence “{demo['sentence']}”.")
        blocks.append(_Table(("panel", "errors", "logs (truth)"), tuple(
            (p["title"], str(p["errors"]), f"{p['logs']} ({p['truth_logs']})")
            for p in demo["panels"])))
    blocks += _note(st)

    # Showcase
    if any(s.name == "showcase" for s in rep.stages):
        st = rep.stage("showcase")
        blocks.append(_Heading(2, "Showcase: one estimate in 3-D"))
        show = st.tables.get("showcase")
        if show:
            caption = (f"{show['name']} at {show['angle']:g}°, the image with the most errors "
                       f"of the visibility stage ({show['errors']}): logs green when right, "
                       "red when wrong, the truth's missed logs faint; drag to turn, click a "
                       "log for its evidence.")
            blocks.append(_Page(show["page"], caption))
        blocks += _note(st)

    blocks.append(_Heading(2, "Files"))
    files = [f for s in rep.stages for f in s.figures]
    blocks.append(_Text("Tables and figures: " + ", ".join(f"[{f}]({f})" for f in files)
                        + ". Everything above, as data: [report.json](report.json)."))
    return blocks


# ---- Markdown -----------------------------------------------------------------------------


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def report_markdown(blocks: list) -> str:
    """The blocks as Markdown (figures linked, the 3-D page linked)."""
    lines: list[str] = []
    for b in blocks:
        if isinstance(b, _Heading):
            lines += [f"{'#' * b.level} {b.text}", ""]
        elif isinstance(b, _Text):
            lines += [b.text, ""]
        elif isinstance(b, _Quote):
            lines += [f"> {b.text}", ""]
        elif isinstance(b, _Table):
            lines.append("| " + " | ".join(_md_cell(h) for h in b.header) + " |")
            lines.append("|" + "---|" * len(b.header))
            lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            lines.append("")
        elif isinstance(b, _Figure):
            lines += [f"![{b.caption}]({b.path})", "", f"*{b.caption}*", ""]
        elif isinstance(b, _Page):
            lines += [f"[The interactive 3-D page]({b.path}) (open it in a browser; it works "
                      f"offline): {b.caption}", ""]
    return "\n".join(lines).rstrip() + "\n"


# ---- HTML ---------------------------------------------------------------------------------

_STYLE = """
body { font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
  color: #1d2533; max-width: 980px; margin: 2em auto; padding: 0 1em; }
h1 { font-size: 1.7em; } h2 { margin-top: 2em; border-bottom: 1px solid #d5dbe3; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #d5dbe3; padding: 4px 10px; text-align: left; vertical-align: top; }
th { background: #eef2f6; }
blockquote { margin: 0.6em 0; padding: 0.3em 1em; border-left: 4px solid #8aa4c2;
  background: #f5f8fb; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #e3e7ec; }
figcaption { font-size: 0.9em; color: #4a5566; }
iframe { width: 100%; height: 560px; border: 1px solid #d5dbe3; }
code { background: #f0f2f5; padding: 0 3px; }
"""


def _inline(text: str) -> str:
    """Escape ``text`` and render its **bold**, *italic*, `code` and [text](link)."""
    out = html.escape(text, quote=True)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    out = re.sub(r"\*\*([^*]+)\*\*", r"<strong>\1</strong>", out)
    out = re.sub(r"(?<![\w*])\*([^*]+)\*(?![\w*])", r"<em>\1</em>", out)
    out = re.sub(r"\[([^\]]+)\]\(([^)\s]+)\)", r'<a href="\2">\1</a>', out)
    return out


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def report_html(blocks: list, folder: str | Path) -> str:
    """The blocks as one self-contained HTML page: the figures read from ``folder`` and
    embedded as base64 PNG, the 3-D page inline (``<iframe srcdoc>``)."""
    folder = Path(folder)
    title = next((b.text for b in blocks if isinstance(b, _Heading)), "report")
    body: list[str] = []
    for b in blocks:
        if isinstance(b, _Heading):
            body.append(f'<h{b.level} id="{_slug(b.text)}">{_inline(b.text)}</h{b.level}>')
        elif isinstance(b, _Text):
            body.append(f"<p>{_inline(b.text)}</p>")
        elif isinstance(b, _Quote):
            body.append(f"<blockquote>{_inline(b.text)}</blockquote>")
        elif isinstance(b, _Table):
            head = "".join(f"<th>{_inline(h)}</th>" for h in b.header)
            rows = "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in row) + "</tr>"
                           for row in b.rows)
            body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
                        if any(b.header) else f"<table><tbody>{rows}</tbody></table>")
        elif isinstance(b, _Figure):
            data = base64.b64encode((folder / b.path).read_bytes()).decode("ascii")
            body.append(f'<figure><img alt="{html.escape(b.caption)}" '
                        f'src="data:image/png;base64,{data}"><figcaption>'
                        f"{_inline(b.caption)}</figcaption></figure>")
        elif isinstance(b, _Page):
            page = (folder / b.path).read_text(encoding="utf-8")
            body.append(f'<figure><iframe title="3-D estimate" sandbox="allow-scripts" '
                        f'srcdoc="{html.escape(page, quote=True)}"></iframe><figcaption>'
                        f"{_inline(b.caption)}</figcaption></figure>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>\n<body>\n"
            + "\n".join(body) + "\n</body></html>\n")


def write_report(rep: Reproduction, folder: str | Path) -> dict[str, Path]:
    """Write ``report.md``, ``report.html`` and ``report.json`` into ``folder`` (which
    holds the run's ``figures/`` and ``showcase/``); return their paths by kind
    (``"markdown"``, ``"html"``, ``"json"``)."""
    folder = Path(folder)
    blocks = report_blocks(rep)
    files = {"markdown": folder / "report.md", "html": folder / "report.html",
             "json": folder / "report.json"}
    write_json(files["json"], rep.to_json())
    atomic_write_bytes(files["markdown"], report_markdown(blocks).encode("utf-8"))
    atomic_write_bytes(files["html"], report_html(blocks, folder).encode("utf-8"))
    return files


#: A Markdown link to a file of the report folder.
_FOLDER_LINK = re.compile(r"\[[^\]]+\]\(((?:figures|showcase)/[^)\s]+|report\.json)\)")
#: Widest figure a published report keeps (pixels); larger ones are scaled down.
PUBLISHED_WIDTH = 960


def publish_report(rep: Reproduction, target: str | Path, *,
                   images: str = "images/results") -> Path:
    """Write the report of ``rep`` (a finished run, its folder holding ``figures/``) as
    one Markdown file ``target`` for a repository's documentation: each figure as a JPEG
    under ``images`` beside it (at most :data:`PUBLISHED_WIDTH` wide), the 3-D page named
    but not copied (it is the report folder's), and a first line saying the file is
    generated. Returns ``target``.

    Raises
    ------
    InputError
        ``target``'s folder does not exist, or the run wrote no report.
    """
    import cv2

    from unseeable.errors import InputError

    target = Path(target)
    if not target.parent.is_dir():
        raise InputError("folder does not exist", field="publish", value=str(target.parent))
    markdown = rep.files.get("markdown")
    if markdown is None:
        raise InputError("the run wrote no report", field="publish", value=str(target))
    folder = Path(markdown).parent
    out_images = target.parent / images
    blocks = []
    pictures: dict[Path, bytes] = {}
    for b in report_blocks(rep):
        if isinstance(b, _Figure):
            image = cv2.imread(str(folder / b.path), cv2.IMREAD_COLOR)
            if image is None:
                raise InputError("figure missing or unreadable", field="publish",
                                 value=str(folder / b.path))
            if image.shape[1] > PUBLISHED_WIDTH:
                scale = PUBLISHED_WIDTH / image.shape[1]
                image = cv2.resize(image, (PUBLISHED_WIDTH, round(image.shape[0] * scale)),
                                   interpolation=cv2.INTER_AREA)
            ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 85])
            name = Path(b.path).with_suffix(".jpg").name
            pictures[out_images / name] = data.tobytes()
            blocks.append(_Figure(f"{images}/{name}", b.caption))
        elif isinstance(b, _Page):
            blocks.append(_Text(f"The interactive 3-D page of this estimate is the report "
                                f"folder's `{b.path}`: {b.caption}"))
        elif isinstance(b, _Text):
            # Links into the report folder do not resolve beside ``target``: named instead.
            blocks.append(_Text(_FOLDER_LINK.sub(r"`\1`", b.text)))
        else:
            blocks.append(b)
    head = _Text("*Generated by `unseeable reproduce --out DIR --publish "
                 f"{target.as_posix()}` from the run described below; not edited by hand.*")
    text = report_markdown([blocks[0], head, *blocks[1:]] if blocks else [head])
    out_images.mkdir(parents=True, exist_ok=True)
    for path, data in pictures.items():
        atomic_write_bytes(path, data)
    atomic_write_bytes(target, text.encode("utf-8"))
    return target
