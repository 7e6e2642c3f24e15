import sys

import pandas as pd
import pytest

import netcosim.plot
from netcosim import Simulation
from netcosim.cli import main
from netcosim.plot import plot_schedule


def test_cli_runs_an_experiment_and_plots_its_schedule(tmp_path, capsys):
    assert main(["run", "servo", "--outdir", str(tmp_path)]) == 0
    sched = tmp_path / "schedule.parquet"
    assert len(pd.read_parquet(sched)) > 100
    out = tmp_path / "s.png"
    assert main(["plot", "schedule", str(sched), "-o", str(out), "--t1", "0.05"]) == 0
    assert out.stat().st_size > 5_000


def test_cli_unknown_experiment(capsys):
    assert main(["run", "no_such_thing"]) == 2
    assert "no experiment 'no_such_thing'" in capsys.readouterr().err


EXPERIMENT_FILE = '''
from pathlib import Path

def main(outdir="default_out", quick=False):
    Path(outdir).mkdir(parents=True, exist_ok=True)
    (Path(outdir) / "ran.txt").write_text(f"main quick={quick}")

def other(outdir="default_out"):
    Path(outdir).mkdir(parents=True, exist_ok=True)
    (Path(outdir) / "ran.txt").write_text("other")
'''


@pytest.mark.parametrize("args, expected", [
    (["./my_experiment.py", "--quick"], "main quick=True"),
    (["my_experiment.py:other"], "other"),
    (["clipkg.exp"], "main quick=False"),
    (["clipkg.exp:other"], "other"),
])
def test_run_accepts_a_file_path_and_a_module_function(tmp_path, monkeypatch, args, expected):
    (tmp_path / "clipkg").mkdir()
    (tmp_path / "clipkg" / "__init__.py").write_text("")
    (tmp_path / "clipkg" / "exp.py").write_text(EXPERIMENT_FILE)
    (tmp_path / "my_experiment.py").write_text(EXPERIMENT_FILE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [str(tmp_path), *sys.path])
    for name in ("clipkg", "clipkg.exp", "my_experiment"):
        monkeypatch.delitem(sys.modules, name, raising=False)
    out = tmp_path / "out"
    assert main(["run", args[0], "--outdir", str(out), *args[1:]]) == 0
    assert (out / "ran.txt").read_text() == expected


def _schedule_file(tmp_path):
    sim = Simulation()
    cpu = sim.node("cpu")

    def body(ctx):
        yield ctx.execute(0.002)
    cpu.periodic(body, period=0.01, priority=1, name="t")
    sim.run(until=0.1)
    path = tmp_path / "schedule.parquet"
    sim.trace.schedule().to_parquet(path)
    return path


def test_plot_errors_are_one_line_exit_2_naming_the_path(tmp_path, capsys):
    corrupt = tmp_path / "corrupt.parquet"
    corrupt.write_bytes(b"PAR1 this is not a parquet file")
    not_schedule = tmp_path / "frame.parquet"
    pd.DataFrame({"time": [0.0], "value": [1.0]}).to_parquet(not_schedule)
    for path in (tmp_path / "missing.parquet", corrupt, not_schedule, tmp_path):
        assert main(["plot", "schedule", str(path), "-o", str(tmp_path / "s.png")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and repr(str(path)) in err[0], err
    assert not (tmp_path / "s.png").exists()


def test_plot_t0_alone_means_from_t0_to_the_end(tmp_path, monkeypatch, capsys):
    sched = _schedule_file(tmp_path)
    windows = []

    def spy(*a, **kw):
        ax = plot_schedule(*a, **kw)
        windows.append(ax.get_xlim())
        return ax
    monkeypatch.setattr(netcosim.plot, "plot_schedule", spy)
    assert main(["plot", "schedule", str(sched), "-o", str(tmp_path / "s.png"), "--t0", "0.05"]) == 0
    # jobs released every 10 ms run 2 ms: the last change is the 0.09 s job ending at 0.092 s
    assert windows == [(0.05, 0.092)]
    assert main(["plot", "schedule", str(sched), "-o", str(tmp_path / "s.png")]) == 0
    assert windows[-1] == (0.0, 0.092)


@pytest.mark.parametrize("t0, t1, named", [
    ("nan", "0.05", "nan"), ("0.0", "nan", "nan"), ("0.05", "0.01", "--t0 0.05 --t1 0.01"),
    ("0.02", "0.02", "--t0 0.02 --t1 0.02"), ("-inf", "0.05", "-inf"),
])
def test_plot_rejects_non_finite_and_reversed_windows(tmp_path, capsys, t0, t1, named):
    sched = _schedule_file(tmp_path)
    out = tmp_path / "s.png"
    assert main(["plot", "schedule", str(sched), "-o", str(out), f"--t0={t0}", f"--t1={t1}"]) == 2
    assert named in capsys.readouterr().err
    assert not out.exists()


def test_plot_schedule_api_windows(tmp_path):
    df = pd.read_parquet(_schedule_file(tmp_path))
    assert plot_schedule(df, t_range=(0.03, None)).get_xlim() == (0.03, 0.092)
    assert plot_schedule(df, t_range=(None, 0.04)).get_xlim() == (0.0, 0.04)
    for bad in ((float("nan"), 0.05), (0.05, 0.01), (0.05, 0.05), (0.0, float("inf")), (0.5, None)):
        with pytest.raises(ValueError, match="t_range"):
            plot_schedule(df, t_range=bad)
