"""The documentation as tests (marker ``docs``: excluded from ``make test``, run by
``make doctest-docs`` and ``.ci/run`` after ``make docs``).

1. Every ``python`` code block of ``docs/*.md`` and ``README.md`` runs: the blocks of a
   page in order in one namespace (that starts as ``from netcosim import *``), each in a
   temporary working directory.  A block that cannot run on its own -- a fragment of a
   larger program, or one that needs what only the text around it provides -- is listed
   in ``FRAGMENTS`` with the reason; every other block must run.
2. The built site (``make docs``, then ``NETCOSIM_DOCS_BUILD=1``): the tutorial's figures
   and every gallery example's figures are in the HTML and are real pictures (file size
   and pixel variance), and the API reference has a page for every name of
   ``netcosim.__all__``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
HTML = ROOT / "build" / "docs" / "html"

pytestmark = pytest.mark.docs

#: (page, index of the python block on the page) -> why it is not run on its own
FRAGMENTS = {
    ("docs/architecture.md", 0): "trace settings of a simulation built elsewhere (sim)",
    ("docs/design.md", 0): "sketch of the ch. 2 scenario with elided arguments (x0=...)",
    ("docs/hil_security.md", 0): "needs a Zenoh configuration file with TLS certificates",
    ("docs/kernel.md", 0): "a task on a simulation and plant built elsewhere (sim, servo)",
    ("docs/kernel.md", 1): "lines of a task body (yield outside a function)",
    ("docs/kernel.md", 3): "servers on a simulation built elsewhere (sim, body)",
    ("docs/lq.md", 0): "the model's matrices come from the text (A, B, C)",
    ("docs/lq.md", 1): "a task of a loop built elsewhere (sim, cpu, model)",
    ("docs/metrics.md", 0): "signals of a run made elsewhere (t, e, sim)",
    ("docs/networks.md", 2): "a method of a MAC class (indented, outside its class)",
    ("docs/networks.md", 3): "needs the module of the MAC it shows (Network's seam imports)",
    ("docs/sweeps.md", 0): "names a study module of the reader's (my_study)",
    ("docs/sweeps.md", 2): "names a study module of the reader's (my_study)",
    ("docs/sweeps.md", 3): "reads a sweep's results directory written by block 0",
    ("docs/viewer.md", 0): "views a simulation built elsewhere (sim)",
    ("docs/fmi.md", 0): "loads an FMU file of the reader's (servo.fmu)",
    ("docs/fmi.md", 1): "loads an FMU file of the reader's (servo.fmu) into a simulation built in block 0",
    ("docs/fmi.md", 2): "loads an FMU file of the reader's (controller.fmu)",
}

_BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def _pages():
    return sorted(DOCS.glob("*.md")) + [ROOT / "README.md"]


def _blocks(page: Path) -> list[str]:
    return _BLOCK.findall(page.read_text(encoding="utf-8"))


def test_fragments_name_existing_blocks():
    for (page, index), reason in FRAGMENTS.items():
        assert index < len(_blocks(ROOT / page)), f"{page} has no python block {index} ({reason}): remove the entry"


@pytest.mark.parametrize("page", _pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_code_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    rel = str(page.relative_to(ROOT))
    namespace: dict = {"__name__": "__docs__"}
    exec("from netcosim import *", namespace)
    ran = 0
    for index, code in enumerate(_blocks(page)):
        if (rel, index) in FRAGMENTS:
            continue
        workdir = tmp_path / f"block{index}"
        workdir.mkdir()
        monkeypatch.chdir(workdir)
        try:
            exec(compile(code, f"{rel}[python block {index}]", "exec"), namespace)
        except Exception as exc:        # noqa: BLE001 - report which block of which page
            raise AssertionError(f"{rel}, python block {index} fails: {type(exc).__name__}: {exc}\n"
                                 f"(a fragment that cannot run on its own goes into FRAGMENTS with why)") from exc
        ran += 1
    if not any(r == rel for r, _ in FRAGMENTS) and not ran:
        pytest.skip(f"{rel} has no python block")


# ---------------------------------------------------------------- the built site
needs_build = pytest.mark.skipif(not os.environ.get("NETCOSIM_DOCS_BUILD"),
                                 reason="set NETCOSIM_DOCS_BUILD=1 after `make docs` to check the built site")


def _images_of(page: Path) -> list[Path]:
    html = page.read_text(encoding="utf-8")
    srcs = re.findall(r'<img[^>]+src="([^"]+\.png)"', html)
    return [(page.parent / s).resolve() for s in srcs if "thumb" not in s]


def _nontrivial(png: Path) -> None:
    import matplotlib.image as mpimg

    assert png.is_file(), f"{png} is referenced but missing"
    assert png.stat().st_size > 5_000, f"{png} is {png.stat().st_size} bytes: not a real figure"
    pixels = mpimg.imread(png)[..., :3]
    assert float(np.std(pixels)) > 0.02, f"{png} is (nearly) one colour: std {np.std(pixels):.4f}"


@needs_build
def test_tutorial_figures_are_in_the_html():
    pages = sorted((HTML / "tutorial_built").glob("step_*.html"))
    assert len(pages) == 5, f"expected the tutorial's 5 steps in {HTML / 'tutorial_built'}, found {pages}"
    counts = {}
    for page in pages:
        images = _images_of(page)
        counts[page.stem] = len(images)
        for png in images:
            _nontrivial(png)
    # every step shows at least one figure; the last two are the cost plot and the timeline
    assert all(n >= 1 for n in counts.values()), counts
    assert counts["step_4_loss_sweep"] >= 1 and counts["step_5_timeline"] >= 1, counts


@needs_build
def test_gallery_figures_are_in_the_html():
    scripts = sorted((DOCS / "gallery_src").glob("plot_*.py"))
    assert len(scripts) >= 20
    for script in scripts:
        page = HTML / "gallery" / f"{script.stem}.html"
        assert page.is_file(), f"no gallery page for {script.name}"
        images = _images_of(page)
        assert images, f"{page.name} shows no figure"
        for png in images:
            _nontrivial(png)


@needs_build
def test_api_reference_has_every_public_name():
    import inspect

    import netcosim

    generated = HTML / "api" / "generated"
    missing = []
    for name in netcosim.__all__:
        obj = getattr(netcosim, name)
        if inspect.isclass(obj) or inspect.isfunction(obj):
            target = f"{obj.__module__}.{obj.__qualname__}"
            if not (generated / f"{target}.html").is_file():
                missing.append(f"{name} ({target})")
    assert not missing, f"no API page for: {missing}"
    assert (HTML / "api" / "index.html").is_file()
    assert (HTML / "from_truetime.html").is_file()


def _iframes_of(page: Path) -> list[Path]:
    html = page.read_text(encoding="utf-8")
    return [(page.parent / s).resolve() for s in re.findall(r'<iframe[^>]+src="([^"]+\.html)"', html)]


@needs_build
def test_interactive_timelines_are_the_pages_the_build_wrote():
    """The tutorial's step 5, the Fly-crane gallery example and the viewer's page embed the
    timelines written during the build; each is a real Bokeh page that draws the run's task
    rows and signals without a JavaScript error (in headless Chromium where it is installed)."""
    embedded = {name: _iframes_of(HTML / name) for name in
                ("tutorial_built/step_5_timeline.html", "gallery/plot_flycrane_network.html", "viewer.html")}
    for name, frames in embedded.items():
        assert len(frames) == 1, f"{name} embeds {frames}"
        assert frames[0].is_file(), f"{name} embeds {frames[0]}, which the build did not write"
        assert frames[0].parent == HTML / "timelines"
    assert embedded["viewer.html"] == embedded["gallery/plot_flycrane_network.html"]
    for page in {f[0] for f in embedded.values()}:
        html = page.read_text(encoding="utf-8")
        assert page.stat().st_size > 200_000 and "Bokeh" in html and "docs_json" in html.replace(" ", "_")
    try:
        import playwright  # noqa: F401

        from netcosim.view.headless import chromium_path, open_view
    except ImportError:
        return
    if chromium_path() is None:
        return
    with open_view(embedded["tutorial_built/step_5_timeline.html"][0]) as page:
        assert page.errors == []
        drawn = page.drawn()
        # the networked loop's three tasks (sample, control, actuate) and the two signals it names
        assert drawn["rows"]["tasks"] == 3
        assert {k for k in drawn["glyphs"] if k.startswith("signal:")} == {"signal:servo.y.y",
                                                                              "signal:sensor.actuate.u"}
    with open_view(embedded["viewer.html"][0]) as page:
        assert page.errors == []
        assert page.drawn()["rows"]["tasks"] >= 5
