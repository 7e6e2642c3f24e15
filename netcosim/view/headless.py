"""Open a view in a real headless browser (Chromium through Playwright) and read what it
drew: used by the tests, the viewer benchmark and the README's screenshot.

Needs the Playwright package (``pip install playwright``, in the ``dev`` extra) and a
Chromium binary: :data:`CHROMIUM` (Debian's ``chromium`` package) unless told otherwise;
Playwright's own browser downloads are not used.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

__all__ = ["CHROMIUM", "chromium_path", "Page", "open_view", "DRAWN_JS"]

#: Where Debian's chromium package puts the browser.
CHROMIUM = "/usr/bin/chromium"

#: Reads the page's Bokeh document: per named renderer the number of drawn glyphs (quads,
#: scatter points, line points), the task rows (tick labels of the tasks panel) and the
#: shared time range.
DRAWN_JS = """() => { const d = Bokeh.documents[0]; const out = {glyphs: {}, rows: {}, range: null};
  for (const m of d._all_models.values()) {
    if (m.name && m.data_source) { const data = m.data_source.data;
      const col = data.left || data.x; out.glyphs[m.name] = col ? col.length : 0; }
    if (m.name === "time") out.range = [m.start, m.end];
    if (m.type === "Figure" || (m.constructor && m.constructor.__name__ === "Figure")) {}
  }
  for (const m of d._all_models.values()) {
    if (m.major_label_overrides && m.major_label_overrides.size !== undefined && m.major_label_overrides.size > 0) {
      const f = [...d._all_models.values()].find(p => p.left && p.left.includes && p.left.includes(m));
      if (f && f.name) out.rows[f.name] = m.major_label_overrides.size; }
  }
  out.updates = window.__ncs_updates || 0; return out; }"""


def chromium_path() -> str | None:
    """The Chromium to drive: ``$NETCOSIM_CHROMIUM``, else :data:`CHROMIUM` or ``chromium`` on
    the PATH; None when there is none."""
    given = os.environ.get("NETCOSIM_CHROMIUM")
    if given:
        return given if Path(given).is_file() else None
    if Path(CHROMIUM).is_file():
        return CHROMIUM
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Page:
    """A view loaded in headless Chromium: ``errors`` (JavaScript errors and console
    errors, in order), ``load_time`` (s from navigation until the first level-of-detail
    update, or until Bokeh's document exists for a page without one), and methods to read
    and move it.  Use as a context manager (closes the browser).

    ``html``: the path of the view's HTML file; ``width``, ``height``: the viewport in
    pixels; ``timeout`` (s): the limit on loading the page and on its first update;
    ``wait_update``: wait for the first level-of-detail update (False: only for Bokeh's
    document, for a page without the update callback)."""

    def __init__(self, html: str | os.PathLike, *, width: int = 1300, height: int = 1000, timeout: float = 120.0,
                 wait_update: bool = True):
        from playwright.sync_api import sync_playwright
        exe = chromium_path()
        if exe is None:
            raise FileNotFoundError(f"no Chromium: install Debian's chromium ({CHROMIUM}) or set NETCOSIM_CHROMIUM")
        self._pw = sync_playwright().start()
        try:
            self._browser = self._pw.chromium.launch(executable_path=exe, args=["--no-sandbox"])
            self.page = self._browser.new_page(viewport={"width": width, "height": height})
            self.errors: list[str] = []
            self.page.on("pageerror", lambda e: self.errors.append(f"page error: {e}"))
            self.page.on("console", lambda m: self.errors.append(f"console error: {m.text}")
                         if m.type == "error" else None)
            start = time.perf_counter()
            self.page.goto(Path(html).resolve().as_uri(), timeout=timeout * 1e3)
            ready = ("window.__ncs_updates >= 1" if wait_update
                     else "window.Bokeh !== undefined && Bokeh.documents.length > 0")
            self.page.wait_for_function(ready, timeout=timeout * 1e3)
            self.load_time = time.perf_counter() - start
        except BaseException:
            self.close()
            raise

    def drawn(self) -> dict[str, Any]:
        """What the page draws now (:data:`DRAWN_JS`)."""
        return self.page.evaluate(DRAWN_JS)

    def wait_updates(self, n: int, timeout: float = 60.0) -> None:
        """Wait until the level-of-detail callback has run *n* times in all, at most *timeout* s."""
        self.page.wait_for_function(f"(window.__ncs_updates || 0) >= {n}", timeout=timeout * 1e3)

    def set_range(self, t0: float, t1: float) -> dict[str, Any]:
        """Set the shared time window to ``[t0, t1]`` (s) as a zoom would; returns :meth:`drawn` after the update."""
        n = self.drawn()["updates"]
        self.page.evaluate(f"""() => {{ const r = [...Bokeh.documents[0]._all_models.values()]
            .find(m => m.name === "time"); r.setv({{start: {t0!r}, end: {t1!r}}}); }}""")
        self.wait_updates(n + 1)
        return self.drawn()

    def screenshot(self, path: str | os.PathLike) -> Path:
        """Write a PNG of the whole page to *path*."""
        self.page.screenshot(path=str(path), full_page=True)
        return Path(path)

    def close(self) -> None:
        """Close the browser and stop Playwright (safe to call twice)."""
        browser, pw = getattr(self, "_browser", None), getattr(self, "_pw", None)
        self._browser = self._pw = None
        for stop in (browser.close if browser is not None else None, pw.stop if pw is not None else None):
            if stop is not None:
                try:
                    stop()
                except Exception:   # noqa: BLE001 - a browser that already went away
                    pass

    def __enter__(self) -> Page:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_view(html: str | os.PathLike, **options: Any) -> Page:
    """:class:`Page` of *html* (a view file) in headless Chromium."""
    return Page(html, **options)
