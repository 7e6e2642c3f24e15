"""The main job isolates experiments: one that exits, hangs or raises does not stop the others."""

from __future__ import annotations

import re

import pytest

from netcosim.experiments import main as main_job

FAKES = {
    "exits": "import sys\nprint('exits: about to call sys.exit(3)')\nsys.exit(3)\n",
    "hangs": "import time\nprint('hangs: sleeping', flush=True)\ntime.sleep(600)\n",
    "raises": ("import argparse, pathlib\n"
               "p = argparse.ArgumentParser(); p.add_argument('--outdir')\n"
               "p.add_argument('--quick', action='store_true')\n"
               "a = p.parse_args()\n"
               "out = pathlib.Path(a.outdir); out.mkdir(parents=True)\n"
               "(out / 'partial.parquet').write_bytes(b'first stage')\n"
               "raise RuntimeError('second stage failed')\n"),
    "works": ("import argparse, pathlib\n"
              "p = argparse.ArgumentParser(); p.add_argument('--outdir')\n"
              "p.add_argument('--quick', action='store_true')\n"
              "a = p.parse_args()\n"
              "out = pathlib.Path(a.outdir); out.mkdir(parents=True)\n"
              "(out / 'result.txt').write_text(f'quick={a.quick}')\n"
              "print('works: done')\n"),
}
#: Seconds before the hanging experiment is stopped (the others need a Python start-up).
TIMEOUT = 3.0


@pytest.fixture
def fake_experiments(tmp_path, monkeypatch):
    pkg = tmp_path / "fake_experiments"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    for name, code in FAKES.items():
        (pkg / f"{name}.py").write_text(code)
    monkeypatch.syspath_prepend(str(tmp_path))      # the runner passes sys.path on to each process
    return [(f"fake_experiments.{name}", f"fake experiment that {name}") for name in FAKES]


def test_failures_are_isolated_reported_and_keep_their_outputs(tmp_path, fake_experiments, capsys):
    out = tmp_path / "results"
    status = main_job.main(out, experiments=fake_experiments, timeout=TIMEOUT, quick=True)
    stdout, stderr = capsys.readouterr()
    assert status == 1
    # every experiment ran, the last one after the three failures
    assert (out / "works" / "result.txt").read_text() == "quick=True"
    assert (out / "raises" / "partial.parquet").read_bytes() == b"first stage"   # never deleted
    # each announced, its own output streamed through (traceback included)
    for name in FAKES:
        assert f"fake_experiments.{name}] fake experiment that {name} -> {out / name}/" in stdout
    assert "exits: about to call sys.exit(3)" in stdout
    assert "RuntimeError: second stage failed" in stdout
    assert "works: done" in stdout
    table = stdout[stdout.index("experiment  "):]
    rows = {line.split()[0]: line for line in table.splitlines()[1:]}
    assert re.search(r"failed \(exit 3\)\s+\d+\.\d\s+" + re.escape(f"{out / 'exits'}/"), rows["fake_experiments.exits"])
    assert re.search(r"timeout \(> 3 s\)\s+(\d+\.\d)", rows["fake_experiments.hangs"])
    assert "failed (exit 1)" in rows["fake_experiments.raises"]
    assert re.search(r"\bok\s+\d+\.\d\s+" + re.escape(f"{out / 'works'}/"), rows["fake_experiments.works"])
    assert stderr.strip() == ("failed: fake_experiments.exits (failed), fake_experiments.hangs (timeout), "
                              "fake_experiments.raises (failed)")


def test_all_ok_exits_zero_and_only_selects(tmp_path, fake_experiments, capsys):
    out = tmp_path / "results"
    assert main_job.main(out, only=["fake_experiments.works"], experiments=fake_experiments, timeout=60) == 0
    assert (out / "works" / "result.txt").read_text() == "quick=False"
    assert sorted(p.name for p in out.iterdir()) == ["works"]
    assert "fake_experiments.exits" not in capsys.readouterr().out


def test_command_line_help_runs_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        main_job.cli(["--help"])
    assert e.value.code == 0
    assert "--timeout" in capsys.readouterr().out
    assert list(tmp_path.iterdir()) == []
