"""Level of detail of the interactive view: the exact rows travel in the page in compact
columns (float64 times, small integer codes), and one small Bokeh ``CustomJS`` callback,
run when the page is ready and whenever the shared time axis moves, fills the drawn
sources from them:

* **lanes** (task states, frame attempts, medium busy periods): when at most
  ``max_glyphs`` intervals overlap the visible window, each is drawn exactly (with its
  hover text); otherwise the window is cut into ``bins`` equal bins (about one per pixel
  column) and each row draws, per bin and category, one bar whose opacity is the fraction
  of the bin the row spent in that category (the busy fraction);
* **signals**: at most ``max_points`` samples in the window are drawn exactly; otherwise
  each bin draws its minimum and maximum (in time order), so peaks stay visible.

Work per update is one pass over the rows up to the window's end (binary search for it).
Each update counts itself in ``window.__ncs_updates`` (the headless tests wait on it).
"""

from __future__ import annotations

#: The callback.  Arguments: ``xr`` (the shared x range), ``lanes`` (list of dicts: ``store``
#: -- source of exact rows ``start, end, row, cat`` and ``info`` codes --, ``outs`` -- one
#: drawn source per category --, ``levels`` -- bar height per category --, ``names`` -- row
#: labels --, ``cats`` -- category names --, ``kind``, ``extra`` -- lookup arrays for the hover
#: text), ``signals`` (list of ``[store, out]``), ``max_glyphs``, ``max_points``, ``bins``.
LOD_JS = r"""
if (window.__ncs_busy) { return; }
window.__ncs_busy = true;
setTimeout(() => { window.__ncs_busy = false; update(); }, 0);
function bisect(a, x) {
  let lo = 0, hi = a.length;
  while (lo < hi) { const m = (lo + hi) >> 1; if (a[m] < x) lo = m + 1; else hi = m; }
  return lo;
}
function f(t) {
  if (t === null || t === undefined || Number.isNaN(t)) return "-";
  return Math.abs(t) < 1 ? (t * 1e3).toFixed(4) + " ms" : t.toFixed(7) + " s";
}
function info(L, i) {
  const d = L.store.data, e = L.extra, lab = L.names[d.row[i]], c = L.cats[d.cat[i]];
  let s = lab + ": " + c + "<br>" + f(d.start[i]) + " to " + f(d.end[i]) + " (" + f(d.end[i] - d.start[i]) + ")";
  const j = d.ref[i];
  if (L.kind === "tasks" && j >= 0) {
    s += "<br>job " + e.job[j] + ": release " + f(e.release[j]) + ", start " + f(e.jstart[j]) +
         "<br>finish " + f(e.finish[j]) + ", deadline " + f(e.deadline[j]) + "<br>response time " + f(e.response[j]);
  } else if (L.kind === "frames") {
    s += "<br>frame " + e.frame[j] + " to " + e.dst_names[e.dst[j]] + ", attempt " + e.attempt[j] +
         "<br>" + e.bits[j] + " bits, end: " + e.reason_names[e.reason[j]];
  } else if (L.kind === "busy") {
    s += "<br>" + j + " attempt(s)";
  }
  return s;
}
function exact(L, idx, out) {
  const d = L.store.data;
  for (const i of idx) {
    const o = out[d.cat[i]];
    o.left.push(d.start[i]); o.right.push(d.end[i]); o.bottom.push(d.row[i]);
    o.top.push(d.row[i] + L.levels[d.cat[i]]); o.alpha.push(0.8); o.info.push(info(L, i));
  }
}
function aggregate(L, hi, t0, t1, w, out) {
  const d = L.store.data, st = d.start, en = d.end, nc = L.cats.length, nr = L.names.length;
  const acc = new Float64Array(nr * nc * bins);
  for (let i = 0; i < hi; i++) {
    const a = Math.max(st[i], t0), b = Math.min(en[i], t1);
    if (b <= a) continue;
    const base = (d.row[i] * nc + d.cat[i]) * bins;
    const k1 = Math.min(bins - 1, Math.floor((b - t0) / w));
    for (let k = Math.min(bins - 1, Math.floor((a - t0) / w)); k <= k1; k++) {
      const lo = t0 + k * w, ov = Math.min(b, lo + w) - Math.max(a, lo);
      if (ov > 0) acc[base + k] += ov;
    }
  }
  for (let r = 0; r < nr; r++) for (let c = 0; c < nc; c++) {
    const base = (r * nc + c) * bins, o = out[c];
    for (let k = 0; k < bins; k++) {
      const v = acc[base + k];
      if (v <= 0) continue;
      const fr = Math.min(1, v / w), lo = t0 + k * w;
      o.left.push(lo); o.right.push(lo + w); o.bottom.push(r); o.top.push(r + L.levels[c]);
      o.alpha.push(0.15 + 0.85 * fr);
      o.info.push(L.names[r] + ": " + L.cats[c] + " " + (100 * fr).toFixed(1) + " % of " + f(lo) + " to " +
                  f(lo + w) + "<br>(aggregated: zoom in for the exact rows)");
    }
  }
}
function decimate(S, O, t0, t1, w) {
  const t = S.data.t, v = S.data.v;
  const lo = Math.max(0, bisect(t, t0) - 1), hi = Math.min(t.length, bisect(t, t1) + 1);
  const x = [], y = [];
  if (hi - lo <= max_points) {
    for (let i = lo; i < hi; i++) { x.push(t[i]); y.push(v[i]); }
  } else {
    let k = -1, imin = 0, imax = 0;
    const flush = () => {
      if (k < 0) return;
      const p = Math.min(imin, imax), q = Math.max(imin, imax);
      x.push(t[p]); y.push(v[p]);
      if (q !== p) { x.push(t[q]); y.push(v[q]); }
    };
    for (let i = lo; i < hi; i++) {
      const b = Math.min(bins - 1, Math.max(0, Math.floor((t[i] - t0) / w)));
      if (b !== k) { flush(); k = b; imin = i; imax = i; }
      else { if (v[i] < v[imin]) imin = i; if (v[i] > v[imax]) imax = i; }
    }
    flush();
  }
  O.data = {x: x, y: y};
}
function update() {
  const t0 = xr.start, t1 = xr.end, w = (t1 - t0) / bins;
  for (const L of lanes) {
    const d = L.store.data, hi = bisect(d.start, t1), idx = [];
    const out = L.cats.map(() => ({left: [], right: [], bottom: [], top: [], alpha: [], info: []}));
    let few = true;
    for (let i = 0; i < hi; i++) {
      if (d.end[i] > t0) { idx.push(i); if (idx.length > max_glyphs) { few = false; break; } }
    }
    if (few) exact(L, idx, out); else aggregate(L, hi, t0, t1, w, out);
    for (let c = 0; c < L.cats.length; c++) L.outs[c].data = out[c];
  }
  for (const [S, O] of signals) decimate(S, O, t0, t1, w);
  window.__ncs_updates = (window.__ncs_updates || 0) + 1;
}
"""
