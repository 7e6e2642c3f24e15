"""One command-line convention for every experiment.

``python -m netcosim.experiments.NAME [--outdir DIR] [--quick] [own options]``: the help text
is the module docstring, ``--outdir`` is where the plots (PNG) and tables (Parquet)
go, ``--quick`` selects the experiment's short run.  Parsing happens before any
computation, so ``--help`` and bad arguments return at once and write nothing.
``main(outdir=..., quick=...)`` stays callable from Python with the same meaning.
"""

from __future__ import annotations

import argparse


def experiment_parser(doc: str, outdir: str, *, quick: str | None = "a shorter run, for a quick check",
                      prog: str | None = None) -> argparse.ArgumentParser:
    """An ``ArgumentParser`` for an experiment module.

    ``doc`` is the module docstring (first line: description; the rest: shown after the
    options); ``outdir`` the default output directory; ``quick`` the help of the
    ``--quick`` flag, or ``None`` for an experiment without a short run.  Add the
    experiment's own options to the returned parser.  ``prog`` defaults to
    ``python -m <module>`` of the running ``-m`` module.
    """
    if prog is None:
        import __main__
        spec = getattr(__main__, "__spec__", None)
        prog = f"python -m {spec.name}" if spec is not None else None
    lines = (doc or "").strip().splitlines()
    p = argparse.ArgumentParser(prog=prog, description=lines[0] if lines else None,
                                epilog="\n".join(lines[1:]).strip() or None,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--outdir", default=outdir, help=f"output directory (default: {outdir})")
    if quick is not None:
        p.add_argument("--quick", action="store_true", help=quick)
    return p
