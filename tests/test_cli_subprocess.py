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


def test_experiments_is_one_of_the_installed_packages():
    # what `pip install .` installs: the packages setuptools finds with pyproject's include list
    from setuptools import find_packages
    conf = tomllib.loads((REPO / "pyproject.toml").read_text())
    include = conf["tool"]["setuptools"]["packages"]["find"]["include"]
    found = set(find_packages(where=str(REPO), include=include))
    assert {"netcosim", "netcosim.kernel", "netcosim.network", "plants", "controllers", "experiments"} <= found
    assert not any(p.startswith("tests") for p in found)


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
    where = subprocess.run([str(py), "-c", "import experiments, netcosim; print(experiments.__file__); "
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
