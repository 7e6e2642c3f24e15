"""The interactive timeline of one run, as one self-contained HTML file (Bokeh, its
JavaScript inlined with :data:`bokeh.resources.INLINE`: no server, opens offline from disk).

Panels, stacked on one shared time axis (simulated seconds):

* **tasks**: one row per task (``"node.task"``, handlers included: they are tasks of the
  schedule table), top row first in order of appearance, with bars of TrueTime's heights
  (running 0.5, ready 0.25, blocked 0.125 of the row; idle: nothing), the marks of
  deadline misses, budget overruns, watchdog firings and HIL events;
* **one panel per network**: a row per sender with its transmission attempts coloured by
  outcome (delivered, lost, collided, retried, dropped) and a ``medium`` row with the
  medium's busy periods;
* **signals**: the chosen plant and controller signals.

Tools: pan along time, box zoom, wheel zoom, reset, hover (job id, release, start,
finish, deadline, response time; frame id, size, retries), a click on a legend entry
hides or shows that category.  The level of detail is :mod:`netcosim.view.lod`'s.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError
from . import segments as sg
from .lod import LOD_JS
from .tables import end_time, read_tables

__all__ = ["write_view", "build_layout", "DEFAULTS"]

#: Level-of-detail defaults: exact glyphs drawn at most per lane set, exact samples per
#: signal, and aggregation bins across the visible window.
DEFAULTS = {"max_glyphs": 4000, "max_points": 4000, "bins": 800}
_PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
            "#17becf")


def _codes(values, names: list[str] | None = None):
    """(int codes, names) of the string *values* (names in order of appearance unless given)."""
    vals = np.asarray(values).astype(str)
    if names is None:
        names = list(dict.fromkeys(vals.tolist()))
    pos = {n: i for i, n in enumerate(names)}
    return np.fromiter((pos[v] for v in vals), np.int32, len(vals)), names


def _quad_sources(fig, cats: Sequence[str], colours: dict, hover_name: str):
    """One empty drawn source and quad renderer per category, each with a legend entry."""
    from bokeh.models import ColumnDataSource
    outs = []
    for c in cats:
        src = ColumnDataSource({"left": [], "right": [], "bottom": [], "top": [], "alpha": [], "info": []})
        fig.quad(left="left", right="right", bottom="bottom", top="top", source=src, fill_color=colours[c],
                 fill_alpha="alpha", line_color=colours[c], line_alpha="alpha", line_width=0.5, legend_label=c,
                 name=f"{hover_name}:{c}")
        outs.append(src)
    return outs


def _figure(title: str, height: int, x_range, rows: list[str], width: int):
    from bokeh.models import FixedTicker, HoverTool
    from bokeh.plotting import figure
    fig = figure(title=title, height=height, width=width, x_range=x_range, y_range=(-0.2, len(rows) + 0.1),
                 tools="xpan,box_zoom,xwheel_zoom,reset,save", active_drag="xpan", active_scroll="xwheel_zoom",
                 output_backend="canvas", name=title, min_border_left=110)
    fig.add_tools(HoverTool(tooltips="<div style='font-size:11px'>@info{safe}</div>"))
    fig.yaxis.ticker = FixedTicker(ticks=[r + 0.25 for r in range(len(rows))])
    fig.yaxis.major_label_overrides = {r + 0.25: lab for r, lab in enumerate(rows)}
    fig.xaxis.axis_label = "time [s]"
    fig.ygrid.grid_line_color = None
    return fig


def _task_lane(tables: dict, x_range, width: int):
    """Figure and lane of the task panel (None without a schedule table)."""
    from bokeh.models import ColumnDataSource
    sched = tables.get("schedule")
    if sched is None or not len(sched):
        return None, None, {}
    jobs = tables.get("jobs")
    t_end = end_time(tables)
    seg = sg.task_segments(sched, jobs, t_end=t_end)
    order = sg.task_order(sched)
    rows = list(reversed(order))                        # top row first, as in the PNG
    row_of = {lab: i for i, lab in enumerate(rows)}
    cats = [c for c in ("running", "ready", "blocked")]
    fig = _figure("tasks", 60 + 30 * len(rows), x_range, rows, width)
    outs = _quad_sources(fig, cats, sg.TASK_COLOURS, "task")
    extra: dict[str, Any] = {k: np.zeros(0) for k in ("job", "release", "jstart", "finish", "deadline", "response")}
    ref = np.full(len(seg), -1, dtype=np.int32)
    if jobs is not None and len(jobs):
        jl = (jobs["node"].astype(str) + "." + jobs["task"].astype(str)).to_numpy()
        extra = {"job": jobs["job"].to_numpy(dtype=np.int64).astype(np.float64),
                 "release": jobs["release"].to_numpy(dtype=float), "jstart": jobs["start"].to_numpy(dtype=float),
                 "finish": jobs["finish"].to_numpy(dtype=float), "deadline": jobs["deadline"].to_numpy(dtype=float),
                 "response": jobs["response_time"].to_numpy(dtype=float)}
        index = {(lab, int(j)): i for i, (lab, j) in enumerate(zip(jl, jobs["job"].to_numpy()))}
        ref = np.fromiter((index.get((lab, int(j)), -1) for lab, j in zip(seg["label"], seg["job"])), np.int32,
                          len(seg))
    store = ColumnDataSource({"start": seg["start"].to_numpy(dtype=float), "end": seg["end"].to_numpy(dtype=float),
                              "row": np.fromiter((row_of[x] for x in seg["label"]), np.uint16, len(seg)),
                              "cat": _codes(seg["state"], cats)[0].astype(np.uint8), "ref": ref})
    lane = {"kind": "tasks", "store": store, "outs": outs, "levels": [sg.TASK_STATES[c] for c in cats],
            "names": rows, "cats": cats, "extra": ColumnDataSource(extra).data}
    return fig, lane, row_of


def _network_lanes(tables: dict, x_range, width: int):
    """(figure, attempts lane, busy lane) per network of the frames table."""
    from bokeh.models import ColumnDataSource
    frames = tables.get("frames")
    if frames is None or not len(frames):
        return []
    att = sg.frame_attempts(frames)
    busy = sg.medium_busy(att)
    out = []
    for net in list(dict.fromkeys(frames["network"].astype(str))):
        a = att[att["network"] == net].reset_index(drop=True)
        b = busy[busy["network"] == net].reset_index(drop=True)
        senders = list(dict.fromkeys(a["src"]))
        rows = list(reversed(senders)) + ["medium"]
        row_of = {n: i for i, n in enumerate(rows)}
        fig = _figure(f"network {net}", max(80 + 30 * len(rows), 200), x_range, rows, width)   # room for the legend
        cats = list(sg.FRAME_OUTCOMES)
        outs = _quad_sources(fig, cats, sg.OUTCOME_COLOURS, f"frame:{net}")
        dst, dst_names = _codes(a["dst"])
        reason, reason_names = _codes(a["reason"])
        extra = {"frame": a["frame"].to_numpy(dtype=np.float64), "attempt": a["attempt"].to_numpy(dtype=np.float64),
                 "bits": a["bits"].to_numpy(dtype=float), "dst": dst, "reason": reason}
        store = ColumnDataSource({"start": a["start"].to_numpy(dtype=float), "end": a["end"].to_numpy(dtype=float),
                                  "row": np.fromiter((row_of[s] for s in a["src"]), np.uint16, len(a)),
                                  "cat": _codes(a["outcome"], cats)[0].astype(np.uint8),
                                  "ref": np.arange(len(a), dtype=np.int32)})
        ex = dict(ColumnDataSource(extra).data)
        ex.update(dst_names=dst_names, reason_names=reason_names)
        lane = {"kind": "frames", "store": store, "outs": outs, "levels": [0.6] * len(cats), "names": rows,
                "cats": cats, "extra": ex}
        bstore = ColumnDataSource({"start": b["start"].to_numpy(dtype=float), "end": b["end"].to_numpy(dtype=float),
                                   "row": np.full(len(b), row_of["medium"], np.uint16),
                                   "cat": np.zeros(len(b), np.uint8), "ref": b["frames"].to_numpy(dtype=np.int32)})
        bouts = _quad_sources(fig, ["medium busy"], {"medium busy": "#555555"}, f"busy:{net}")
        blane = {"kind": "busy", "store": bstore, "outs": bouts, "levels": [0.6], "names": rows,
                 "cats": ["medium busy"], "extra": {}}
        out.append((fig, lane, blane))
    return out


def _signal_pairs(sig, signals) -> list[tuple[str, str]]:
    pairs = list(dict.fromkeys(zip(sig["source"].astype(str), sig["signal"].astype(str))))
    if signals is None:
        return pairs[:8]
    chosen = []
    full = {f"{a}.{b}": (a, b) for a, b in pairs}
    for s in signals:
        pair = full.get(s) if isinstance(s, str) else (tuple(str(x) for x in s) if len(s) == 2 else None)
        if pair not in pairs:
            raise ConfigurationError(f"no signal {s!r} in the signals table; have {list(full)[:30]}")
        chosen.append(pair)
    return chosen


def _signal_figure(tables: dict, signals, x_range, width: int):
    from bokeh.models import ColumnDataSource
    from bokeh.plotting import figure
    sig = tables.get("signals")
    if signals is not None and len(signals) and (sig is None or not len(sig)):
        raise ConfigurationError(f"no signal {signals[0]!r}: the run logged no signal")
    if sig is None or not len(sig) or (signals is not None and not len(signals)):
        return None, []
    pairs = _signal_pairs(sig, signals)
    fig = figure(title="signals", height=260, width=width, min_border_left=110, x_range=x_range,
                 tools="xpan,box_zoom,wheel_zoom,reset,save", active_drag="xpan", name="signals")
    fig.xaxis.axis_label = "time [s]"
    src, name = sig["source"].astype(str).to_numpy(), sig["signal"].astype(str).to_numpy()
    t_all, v_all = sig["time"].to_numpy(dtype=float), sig["value"].to_numpy(dtype=float)
    pairs_out = []
    for k, (a, b) in enumerate(pairs):
        sel = (src == a) & (name == b)
        t, v = t_all[sel], v_all[sel]
        o = np.argsort(t, kind="stable")
        store = ColumnDataSource({"t": t[o], "v": v[o]})
        out = ColumnDataSource({"x": [], "y": []})
        fig.line("x", "y", source=out, color=_PALETTE[k % len(_PALETTE)], legend_label=f"{a}.{b}",
                 name=f"signal:{a}.{b}")
        pairs_out.append([store, out])
    return fig, pairs_out


def _marks(fig, tables: dict, row_of: dict) -> None:
    """Scatter the marks on the task panel, on the row of their task (or of the first task
    of their node; else above the top row), at its label's height."""
    from bokeh.models import ColumnDataSource
    mk = sg.marks(tables)
    if not len(mk):
        return
    top = len(row_of)
    by_node: dict[str, int] = {}
    for lab, r in row_of.items():
        by_node.setdefault(lab.split(".", 1)[0], r)
    ys = [row_of.get(w, by_node.get(w, by_node.get(w.split(".", 1)[0], top - 0.4))) + 0.3 for w in mk["where"]]
    mk = mk.assign(y=ys)
    glyph = {"deadline_miss": "inverted_triangle", "budget_overrun": "diamond", "watchdog": "square_x",
             "hil": "circle_x"}
    for kind in sg.MARK_KINDS:
        part = mk[mk["kind"] == kind]
        if not len(part):
            continue
        info = [f"{w}: {t} at {x:.9g} s" for w, t, x in zip(part["where"], part["text"], part["time"])]
        src = ColumnDataSource({"x": part["time"].to_numpy(dtype=float), "y": part["y"].to_numpy(dtype=float),
                                "info": info})
        fig.scatter("x", "y", source=src, marker=glyph[kind], size=9, color=sg.MARK_COLOURS[kind],
                    legend_label=kind.replace("_", " "), name=f"mark:{kind}")


def _t_start(tables: dict) -> float:
    starts = [float(df["time"].min()) for n, df in tables.items() if n != "jobs" and len(df) and "time" in df]
    return min(starts) if starts else 0.0


def build_layout(tables: dict, *, signals: Sequence | None = None, t_range=None, title: str = "netcosim run",
                 width: int = 1200, **lod):
    """The Bokeh layout of the timeline of *tables* (``{name: DataFrame}``, see
    :func:`netcosim.view.tables.read_tables`).  ``signals``: ``"source.signal"`` names or
    ``(source, signal)`` pairs (default: the first 8 logged; ``[]``: no signal panel);
    ``t_range = (t0, t1)`` (s): the initial window (default: the whole run); ``width`` in
    pixels; ``title``: the heading shown above the timeline; ``max_glyphs``, ``max_points``,
    ``bins``: the level of detail (:data:`DEFAULTS`)."""
    from bokeh.layouts import column
    from bokeh.models import CustomJS, Div, Range1d
    opts = dict(DEFAULTS)
    unknown = sorted(set(lod) - set(DEFAULTS))
    if unknown:
        raise ConfigurationError(f"unknown view options {unknown}; the level-of-detail options are {list(DEFAULTS)}")
    for k, v in lod.items():
        if not isinstance(v, int) or isinstance(v, bool) or v < 1:
            raise ConfigurationTypeError(f"{k} must be a positive integer, got {v!r}")
        opts[k] = v
    lo, hi = _t_start(tables), end_time(tables)
    if hi <= lo:
        hi = lo + 1e-9
    t0, t1 = (lo, hi) if t_range is None else (lo if t_range[0] is None else float(t_range[0]),
                                               hi if t_range[1] is None else float(t_range[1]))
    if not t1 > t0:
        raise ConfigurationError(f"t_range={t_range!r} is empty or reversed: need t1 > t0")
    x_range = Range1d(t0, t1, bounds=(lo, hi), name="time")
    figs, lanes = [], []
    fig, lane, row_of = _task_lane(tables, x_range, width)
    if fig is not None:
        _marks(fig, tables, row_of)
        figs.append(fig)
        lanes.append(lane)
    for nfig, a, b in _network_lanes(tables, x_range, width):
        figs.append(nfig)
        lanes += [a, b]
    sfig, sigs = _signal_figure(tables, signals, x_range, width)
    if sfig is not None:
        figs.append(sfig)
    for f in figs:     # legends beside the plots, a click hides a category
        f.legend.click_policy = "hide"
        f.legend.label_text_font_size = "9pt"
        f.add_layout(f.legend[0], "right")
    if not figs:
        raise ConfigurationError(f"nothing to view: no schedule, frames or signals table among {sorted(tables)}")
    cb = CustomJS(args=dict(xr=x_range, lanes=lanes, signals=sigs, bins=opts["bins"],
                            max_glyphs=opts["max_glyphs"], max_points=opts["max_points"]), code=LOD_JS)
    x_range.js_on_change("start", cb)
    x_range.js_on_change("end", cb)
    head = Div(text=f"<b>{title}</b> &mdash; {lo:.6g} s to {hi:.6g} s; drag to pan, box or wheel to zoom, "
                    f"click a legend entry to hide it; zoomed out, bars show the fraction of each pixel column "
                    f"spent in a state", name="header")
    layout = column(head, *figs, name="timeline")
    return layout, cb


def write_view(source: Any, path: str | os.PathLike | None = None, *, title: str | None = None,
               prefix: str = "", **options: Any) -> Path:
    """Write the interactive timeline of *source* to *path* (default ``view.html``); returns the path.

    *source*: a Trace, a Simulation, a dict of DataFrames or a directory of
    ``Trace.to_parquet`` files (``prefix``: their name prefix); ``title``: the page's title
    and heading (None: ``"netcosim run"``); *options*: those of
    :func:`build_layout`.  The file holds every row of the drawn tables and Bokeh's
    JavaScript (about 1.6 MB without data): it needs neither a server nor a network."""
    from bokeh.document import Document
    from bokeh.embed import file_html
    from bokeh.resources import INLINE
    tables = read_tables(source, prefix=prefix)
    out = Path("view.html" if path is None else path)
    if out.is_dir():
        out = out / "view.html"
    if not out.parent.is_dir():
        raise ConfigurationError(f"cannot write {str(out)!r}: the folder {str(out.parent)!r} does not exist")
    layout, cb = build_layout(tables, title=title or "netcosim run", **options)
    doc = Document()
    doc.add_root(layout)
    doc.js_on_event("document_ready", cb)
    html = file_html(doc, INLINE, title=title or "netcosim run")
    out.write_text(html, encoding="utf-8")
    return out
