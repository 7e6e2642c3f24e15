import pandas as pd

from netcosim.cli import main


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
