"""Experiments answer ``--help`` without running, and importing them leaves matplotlib alone."""

from __future__ import annotations

import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import netcosim.experiments

REPO = Path(__file__).resolve().parents[1]
MODULES = sorted(f"netcosim.experiments.{m.name}" for m in pkgutil.iter_modules(netcosim.experiments.__path__)
                 if not m.name.startswith("_"))
#: Programs that stand in for a remote node (hardware in the loop): they answer --help but
#: write no results, so they have no --outdir
REMOTE_PROCESSES = {"netcosim.experiments.hil_servo_controller", "netcosim.experiments.hil_landing_llc_controller",
                    "netcosim.experiments.hil_flycrane_node"}
#: Seconds a `--help` may take: imports only (a full run takes seconds to minutes).
HELP_TIMEOUT = 120


def _env(**extra):
    return dict(os.environ, PYTHONPATH=str(REPO), **extra)


def test_the_experiment_list_is_complete():
    assert len(MODULES) == 31 and "netcosim.experiments.hil_servo" in MODULES
    assert "netcosim.experiments.flycrane_network" in MODULES and "netcosim.experiments.gateway" in MODULES
    assert "netcosim.experiments.aodv" in MODULES and "netcosim.experiments.multicore_dhall" in MODULES
    assert "netcosim.experiments.wireless_tpc" in MODULES
    assert "netcosim.experiments.dvs" in MODULES
    assert "netcosim.experiments.fidelity" in MODULES and "netcosim.experiments.hil_landing_llc" in MODULES
    assert "netcosim.experiments.main" in MODULES and "netcosim.experiments.servo" in MODULES
    assert "netcosim.experiments.clock_sync" in MODULES
    assert "netcosim.experiments.jitterbug_servo" in MODULES
    assert "netcosim.experiments.expected_cost_loss" in MODULES


HELP_ALL = """
import contextlib, io, json, os, runpy, sys, warnings
import matplotlib
matplotlib.use("svg")               # the user's choice, which importing netcosim must keep
import netcosim.plot, netcosim.network.plot
warnings.simplefilter("ignore")     # runpy: module already imported by a sibling
results = {"backend": matplotlib.get_backend()}
for mod, cwd in json.loads(sys.argv[1]).items():
    os.chdir(cwd)
    sys.argv = [mod, "--help"]
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            runpy.run_module(mod, run_name="__main__", alter_sys=True)
        code = "returned without exiting"
    except SystemExit as e:
        code = e.code
    results[mod] = [code, out.getvalue()]
results["backend after"] = matplotlib.get_backend()
print(json.dumps(results))
"""


@pytest.fixture(scope="module")
def help_of_all(tmp_path_factory):
    """Run every module's ``--help`` in one process (the imports are shared), each in its
    own empty directory, after choosing the svg backend; returns (results, dirs)."""
    tmp_path = tmp_path_factory.mktemp("help")
    dirs = {}
    for mod in MODULES:
        dirs[mod] = tmp_path / mod
        dirs[mod].mkdir()
    env = _env()
    env.pop("MPLBACKEND", None)
    r = subprocess.run([sys.executable, "-c", HELP_ALL, json.dumps({m: str(d) for m, d in dirs.items()})],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=HELP_TIMEOUT)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1]), dirs


def test_every_experiment_answers_help_and_writes_nothing(help_of_all):
    # a module that runs instead of printing its help writes files (or exceeds the timeout)
    results, dirs = help_of_all
    for mod in MODULES:
        code, out = results[mod]
        assert code == 0 and "usage: python -m " + mod in out, (mod, code, out)
        assert ("--outdir" in out) != (mod in REMOTE_PROCESSES), (mod, out)
        assert sorted(x.name for x in dirs[mod].iterdir()) == [], mod


@pytest.mark.slow
def test_every_experiment_answers_help_quickly_and_writes_nothing(tmp_path):
    # all at once: each process spends its time importing numpy/pandas/matplotlib/casadi
    procs = {}
    for mod in MODULES:
        cwd = tmp_path / mod
        cwd.mkdir()
        procs[mod] = (cwd, subprocess.Popen([sys.executable, "-m", mod, "--help"], cwd=cwd,
                                            env=_env(MPLBACKEND="Agg"), stdout=subprocess.PIPE,
                                            stderr=subprocess.PIPE, text=True))
    failures = []
    for mod, (cwd, p) in procs.items():
        try:
            out, err = p.communicate(timeout=HELP_TIMEOUT)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            failures.append(f"{mod}: still running after {HELP_TIMEOUT} s (it ran instead of helping)")
            continue
        if p.returncode != 0 or "usage:" not in out or ("--outdir" in out) == (mod in REMOTE_PROCESSES):
            failures.append(f"{mod}: exit {p.returncode}\n{out}\n{err}")
        written = sorted(x.name for x in cwd.iterdir())
        if written:
            failures.append(f"{mod}: --help wrote {written}")
    assert not failures, "\n".join(failures)


def test_importing_plots_and_experiments_keeps_the_users_backend(help_of_all):
    results, _ = help_of_all
    assert (results["backend"], results["backend after"]) == ("svg", "svg")
