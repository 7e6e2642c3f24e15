"""The ``netcosim`` command as a user runs it: a separate process, from another directory.

In-process calls of ``netcosim.cli.main`` from the repository root hide packaging
mistakes (a package that is importable only because the current directory is the
repository); these tests run ``python -m netcosim.cli`` from an empty temporary
directory, and the slow one installs the project into a new virtual environment.
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

import pandas as pd
import pytest

REPO = Path(__file__).resolve().parents[1]


def netcosim_cli(args, cwd, *, timeout=120):
    """Run ``python -m netcosim.cli ARGS`` in *cwd* with this checkout's code first on the path."""
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "netcosim.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def test_the_installed_packages_are_the_tree_under_one_namespace():
    # what `pip install .` installs: pyproject's package list, the repository's folders
    # plants/, controllers/, experiments/ mapped under netcosim (package-dir)
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    mapping = {"netcosim": "netcosim", **conf["package-dir"]}
    assert conf["package-dir"] == {f"netcosim.{d}": d for d in ("plants", "controllers", "experiments")}
    tree = set()
    for name, folder in mapping.items():
        for init in (REPO / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO / folder).parts
            tree.add(".".join((name, *rel)))
    assert sorted(conf["packages"]) == sorted(tree)
    assert not any(p.split(".")[0] != "netcosim" for p in conf["packages"])


def _user_project(root: Path) -> Path:
    """A user's directory with packages named like the repository's folders, and an
    experiment of its own that uses the installed plant and controller."""
    for pkg in ("plants", "controllers", "experiments"):
        (root / pkg).mkdir(parents=True)
        (root / pkg / "__init__.py").write_text("OWNER = 'user'\n")
    (root / "plants" / "dc_servo.py").write_text("raise ImportError('the user plants.dc_servo was imported')\n")
    (root / "controllers" / "pid.py").write_text("raise ImportError('the user controllers.pid was imported')\n")
    (root / "experiments" / "servo.py").write_text("raise ImportError('the user experiments.servo was imported')\n")
    (root / "experiments" / "mine.py").write_text(
        "from netcosim import Simulation\n"
        "from netcosim.controllers.pid import PID\n"
        "from netcosim.plants.dc_servo import DCServo\n"
        "import plants\n\n"
        "def main(outdir=None, quick=False):\n"
        "    sim = Simulation()\n"
        "    sim.plant(DCServo(), x0=[0.0, 0.0], name='servo')\n"
        "    sim.run(0.1)\n"
        "    print('mine', plants.OWNER, DCServo.__module__, type(PID(h=0.006)).__module__)\n")
    return root


def test_a_user_directory_with_its_own_experiments_and_plants(tmp_path):
    """``netcosim run`` and the documented imports work from a directory holding the user's
    own ``experiments``, ``plants`` and ``controllers`` packages: the repository's are
    ``netcosim.experiments`` ..., the user's keep their names."""
    work = _user_project(tmp_path / "project")
    r = netcosim_cli(["run", "servo", "--quick", "--outdir", str(tmp_path / "out")], cwd=work)
    assert r.returncode == 0, r.stderr
    assert len(pd.read_parquet(tmp_path / "out" / "jobs.parquet")) == 84
    r = netcosim_cli(["run", "experiments.mine:main"], cwd=work)
    assert r.returncode == 0, r.stderr
    assert "mine user netcosim.plants.dc_servo netcosim.controllers.pid" in r.stdout
    env = dict(os.environ, PYTHONPATH=str(REPO))
    code = ("import experiments, plants, controllers, netcosim.experiments.servo as s, netcosim.plants.flycrane; "
            "print(experiments.OWNER, plants.OWNER, controllers.OWNER, s.__name__)")
    out = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.stdout.split() == ["user", "user", "user", "netcosim.experiments.servo"], out.stderr


def test_run_servo_from_an_unrelated_directory(tmp_path):
    work = tmp_path / "elsewhere"
    work.mkdir()
    out = tmp_path / "out"
    r = netcosim_cli(["run", "servo", "--outdir", str(out), "--quick"], cwd=work)
    assert r.returncode == 0, r.stderr
    # --quick: 0.5 s at a 6 ms period -> releases at 0, 6, ..., 498 ms = 84 jobs
    assert len(pd.read_parquet(out / "jobs.parquet")) == 84
    for f in ("servo_output.png", "servo_schedule.png", "schedule.parquet", "signals.parquet"):
        assert (out / f).stat().st_size > 1000, f
    assert list(work.iterdir()) == []      # nothing written in the current directory


def _venv_python(venv: Path) -> Path:
    return venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_installed_package_runs_servo_from_a_temporary_directory(tmp_path):
    """``pip install`` (not editable) into a new venv, then ``netcosim run servo`` from a temp dir.

    The new environment sees this environment's dependencies through a ``.pth`` file
    (no download), installs the project with ``--no-deps --no-build-isolation``, and
    the copy it installs comes from a copy of the sources, so nothing is built in the
    repository.
    """
    src = tmp_path / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(
        ".git", ".venv", "results", "build", "*.egg-info", "__pycache__", ".pytest_cache", "tests"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=300)
    py = _venv_python(venv)
    venv_site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip()
    parent_sites = [p for p in site.getsitepackages() + [sysconfig.get_paths()["purelib"]] if os.path.isdir(p)]
    Path(venv_site, "parent_environment.pth").write_text("\n".join(dict.fromkeys(parent_sites)) + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env["MPLBACKEND"] = "Agg"
    subprocess.run([str(py), "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index",
                    str(src)], check=True, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    work = tmp_path / "work"
    work.mkdir()
    where = subprocess.run([str(py), "-c", "import netcosim.experiments, netcosim; "
                            "print(netcosim.experiments.__file__); "
                            "print(netcosim.__file__)"], cwd=work, env=env, check=True, capture_output=True,
                           text=True).stdout.split()
    assert all(Path(w).is_relative_to(venv) for w in where), where
    script = py.parent / ("netcosim.exe" if os.name == "nt" else "netcosim")
    r = subprocess.run([str(script), "run", "servo", "--outdir", "X"], cwd=work, env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    for f in ("servo_output.png", "servo_schedule.png"):
        assert (work / "X" / f).stat().st_size > 5000, f
    assert len(pd.read_parquet(work / "X" / "jobs.parquet")) == 334     # 2 s at a 6 ms period
