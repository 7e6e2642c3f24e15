"""``netcosim run NAME`` runs the entry point NAME of the group ``netcosim.experiments``.

The framework imports no experiment by name: every runnable experiment is declared in
pyproject.toml's ``[project.entry-points."netcosim.experiments"]``, and a package installed
next to netcosim can register its own the same way.
"""

from __future__ import annotations

import inspect
import re
import sys
import tomllib
from pathlib import Path

import pytest

from netcosim.cli import available_experiments, main, resolve_experiment
from netcosim.cli.run import EXPERIMENT_GROUP

REPO = Path(__file__).resolve().parents[1]

THIRD_PARTY = '''
from pathlib import Path

def study(outdir="default_out", quick=False):
    Path(outdir).mkdir(parents=True, exist_ok=True)
    (Path(outdir) / "ran.txt").write_text(f"third-party study quick={quick}")

def main(outdir="default_out"):
    raise AssertionError("the entry point names study, not main")
'''


@pytest.fixture
def third_party(tmp_path, monkeypatch):
    """An installed distribution (a ``.dist-info`` on ``sys.path``) registering the experiment
    ``thirdparty_study = "thirdparty_mod:study"``."""
    site = tmp_path / "site"
    dist = site / "thirdparty_exp-1.0.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdparty-exp\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(f"[{EXPERIMENT_GROUP}]\nthirdparty_study = thirdparty_mod:study\n"
                                           "thirdparty_missing = thirdparty_nowhere:main\n")
    (site / "thirdparty_mod.py").write_text(THIRD_PARTY)
    monkeypatch.setattr(sys, "path", [str(site), *sys.path])
    monkeypatch.delitem(sys.modules, "thirdparty_mod", raising=False)
    return tmp_path


def test_a_registered_entry_point_is_what_run_runs(third_party, capsys):
    assert "thirdparty_study" in available_experiments()
    out = third_party / "out"
    assert main(["run", "thirdparty_study", "--outdir", str(out), "--quick"]) == 0
    assert (out / "ran.txt").read_text() == "third-party study quick=True"
    assert "thirdparty_mod.study(outdir=" in capsys.readouterr().out


def test_an_entry_point_naming_a_missing_module_is_a_usage_error(third_party, capsys):
    assert main(["run", "thirdparty_missing"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'thirdparty_nowhere'" in err[0] and "thirdparty_nowhere:main" in err[0], err


def test_a_mistyped_name_lists_the_registered_ones(third_party, capsys):
    assert main(["run", "thirdparty_stduy"]) == 2
    err = capsys.readouterr().err
    assert "did you mean 'thirdparty_study'?" in err and "servo" in err and EXPERIMENT_GROUP in err


def _declared() -> dict[str, str]:
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())
    return conf["project"]["entry-points"][EXPERIMENT_GROUP]


def test_every_experiment_with_main_outdir_is_registered():
    # what `netcosim run NAME` found before the entry points: experiments/NAME.py with def main(outdir...)
    shipped = {f.stem for f in (REPO / "experiments").glob("*.py") if not f.stem.startswith("_")
               and re.search(r"^def main\(\s*outdir\b", f.read_text(encoding="utf-8"), re.M)}
    declared = _declared()
    assert shipped <= set(declared), sorted(shipped - set(declared))
    assert set(declared) <= set(available_experiments()), "refresh the install: pip install -e . --no-deps"


@pytest.mark.parametrize("name", sorted(_declared()))
def test_every_registered_experiment_is_an_entry_point_taking_outdir(name):
    fn = resolve_experiment(name)
    assert f"{fn.__module__}:{fn.__qualname__}" == _declared()[name]
    assert "outdir" in inspect.signature(fn).parameters
