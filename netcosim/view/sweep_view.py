"""The HTML view of a stored sweep: a metric (the cost) against a parameter, every run a
dot, the median across seeds a line and its seed band (the inter-quantile band of
:func:`netcosim.sweep.aggregate.summarize`) shaded; one colour per value of a second
parameter.  Clicking a dot opens that run's timeline when the sweep kept its trace.

Traces are kept per run by the scenario itself (an opt-in): it returns the tables of
:func:`netcosim.view.trace_tables` (``trace_schedule``, ``trace_frames``, ...), which the
sweep stores as ``DIR/tables/trace_NAME/run-CCCCCC-SSSSSS.parquet``.  The view then
writes each such run's timeline beside the sweep page as ``runs/run-CCCCCC-SSSSSS.html``
(each file self-contained: about 1.7 MB of Bokeh plus the run's rows) and links the dot to
it; runs without a trace are drawn hollow and open nothing.

The sweep directory is read directly (``sweep.json``, ``runs.parquet`` or ``parts/``),
without a lock, so a sweep still running can be viewed.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigurationError

__all__ = ["write_sweep_view", "read_runs", "TRACE_PREFIX"]

#: Name prefix of the per-run trace tables a scenario returns (:func:`netcosim.view.trace_tables`).
TRACE_PREFIX = "trace_"


def _part(case: int, seed_index: int) -> str:
    return f"run-{case:06d}-{seed_index:06d}"


def read_runs(directory: str | os.PathLike):
    """``(runs, meta)``: the run table of the sweep in *directory* with a ``case`` column
    (index into ``meta["cases"]``) and ``meta`` (``sweep.json``).  Raises
    :class:`~netcosim.errors.ConfigurationError` naming a directory that holds no sweep."""
    import pandas as pd
    root = Path(directory)
    meta_path = root / "sweep.json"
    if not meta_path.is_file():
        raise ConfigurationError(f"{os.fspath(directory)!r} holds no sweep (no sweep.json)")
    meta = json.loads(meta_path.read_text())
    parts = sorted((root / "parts").glob("run-*.parquet"))
    if not parts and not (root / "runs.parquet").is_file():
        raise ConfigurationError(f"the sweep in {os.fspath(directory)!r} has no finished run yet")
    frames = []
    for p in parts:
        _, c, s = p.stem.split("-")
        frames.append(pd.read_parquet(p).assign(case=int(c), seed_index=int(s)))
    runs = pd.concat(frames, ignore_index=True) if frames else pd.read_parquet(root / "runs.parquet")
    if "case" not in runs.columns:
        index = {json.dumps(c, sort_keys=True): i for i, c in enumerate(meta["cases"])}
        runs["case"] = [index.get(json.dumps({k: r[k] for k in meta["params"]}, sort_keys=True, default=str), -1)
                        for r in runs.to_dict("records")]
    return runs.sort_values(["case", "seed_index"], kind="stable").reset_index(drop=True), meta


def _run_tables(root: Path, case: int, seed_index: int) -> dict:
    import pandas as pd
    out = {}
    for d in sorted((root / "tables").glob(TRACE_PREFIX + "*")):
        f = d / f"{_part(case, seed_index)}.parquet"
        if f.is_file():
            out[d.name[len(TRACE_PREFIX):]] = pd.read_parquet(f)
    return out


def write_sweep_view(directory: str | os.PathLike, path: str | os.PathLike | None = None, *, y: str | None = None,
                     x: str | None = None, hue: str | None = None, log_y: bool = False,
                     quantiles: tuple[float, float] = (0.1, 0.9), run_views: bool = True,
                     **view_options: Any) -> Path:
    """Write the sweep page of the sweep stored in *directory* to *path* (default
    ``DIR/view.html``) and, with ``run_views``, the timeline of every run that kept its trace
    to ``runs/run-CCCCCC-SSSSSS.html`` beside it; returns the page's path.

    ``y``: the metric (default the first numeric metric: ``cost`` if there is one); ``x``:
    the parameter on the axis (default the first one that varies); ``hue``: a parameter
    with one colour per value (default the next one that varies); ``quantiles``: the seed
    band; ``log_y``: a logarithmic metric axis; *view_options*: those of
    :func:`netcosim.view.bokeh_timeline.build_layout` for the run timelines."""
    from bokeh.embed import file_html
    from bokeh.models import ColumnDataSource, HoverTool, OpenURL, TapTool
    from bokeh.plotting import figure
    from bokeh.resources import INLINE

    from ..sweep.aggregate import summarize
    from .bokeh_timeline import write_view
    root = Path(directory)
    runs, meta = read_runs(root)
    params = list(meta["params"])
    varying = [p for p in params if runs[p].nunique(dropna=False) > 1] or params
    x = x or varying[0]
    hue = hue if hue is not None else (varying[1] if len(varying) > 1 else None)
    skip = set(params) | {"seed_index", "seed", "case", "status", "error", "traceback", "wall_time"}
    metrics = [c for c in runs.columns if c not in skip and np.issubdtype(runs[c].dtype, np.number)]
    if y is None:
        if not metrics:
            raise ConfigurationError(f"the sweep in {str(root)!r} has no numeric metric to plot")
        y = "cost" if "cost" in metrics else metrics[0]
    if y not in runs.columns:
        raise ConfigurationError(f"no metric {y!r} in the sweep; metrics: {metrics}")
    out = root / "view.html" if path is None else Path(path)
    if not out.parent.is_dir():
        raise ConfigurationError(f"cannot write {str(out)!r}: the folder {str(out.parent)!r} does not exist")
    urls = []
    for case, s in zip(runs["case"], runs["seed_index"]):
        tables = _run_tables(root, int(case), int(s)) if run_views else {}
        if tables:
            (out.parent / "runs").mkdir(exist_ok=True)
            target = out.parent / "runs" / f"{_part(int(case), int(s))}.html"
            write_view(tables, target, title=f"{root.name}: case {case} seed index {s}", **view_options)
            urls.append(f"runs/{target.name}")
        else:
            urls.append("")
    palette = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf")
    fig = figure(title=f"{y} versus {x} (median across seeds, band {quantiles[0]:g} to {quantiles[1]:g} quantile)",
                 width=900, height=500, y_axis_type="log" if log_y else "linear",
                 tools="pan,box_zoom,wheel_zoom,reset,save,tap", name="sweep")
    fig.xaxis.axis_label, fig.yaxis.axis_label = x, y
    groups = [(None, runs)] if hue is None else list(runs.groupby(hue, sort=True))
    for k, (value, g) in enumerate(groups):
        colour = palette[k % len(palette)]
        label = f"{hue} = {value}" if hue is not None else y
        summ = summarize(g, x=x, y=y, quantiles=quantiles,
                         diverged="diverged" if "diverged" in g.columns else None)
        fig.varea(x=summ[x].to_numpy(dtype=float), y1=summ["q_low"].to_numpy(dtype=float),
                  y2=summ["q_high"].to_numpy(dtype=float), fill_color=colour, fill_alpha=0.2, legend_label=label)
        fig.line(summ[x].to_numpy(dtype=float), summ["median"].to_numpy(dtype=float), color=colour, line_width=2,
                 legend_label=label)
        sel = g.index.to_numpy()
        src = ColumnDataSource({"x": g[x].to_numpy(dtype=float), "y": g[y].to_numpy(dtype=float),
                                "seed": g["seed"].astype(str).to_numpy(), "seed_index": g["seed_index"].to_numpy(),
                                "case": g["case"].to_numpy(), "url": [urls[i] for i in sel],
                                "fill": [colour if urls[i] else "white" for i in sel],
                                "trace": ["click: open its timeline" if urls[i] else "no trace kept" for i in sel]})
        fig.scatter("x", "y", source=src, size=8, line_color=colour, fill_color="fill", legend_label=label,
                    name="runs")
    fig.add_tools(HoverTool(tooltips=[(x, "@x"), (y, "@y"), ("case", "@case"), ("seed", "@seed"),
                                      ("", "@trace")], renderers=fig.select(name="runs")))
    tap = fig.select_one(TapTool)
    tap.renderers = list(fig.select(name="runs"))
    tap.callback = OpenURL(url="@url", same_tab=False)
    fig.legend.click_policy = "hide"
    fig.add_layout(fig.legend[0], "right")
    out.write_text(file_html(fig, INLINE, title=f"sweep {root.name}"), encoding="utf-8")
    return out
