"""The networked servo experiment runs, writes its plots, and shows what it claims."""

import pytest

from netcosim.experiments import networked_servo


def test_networked_servo_quick(tmp_path):
    runs = networked_servo.main(outdir=str(tmp_path), quick=True)
    for name in ("outputs.png", "cost.png", "csma_cd_schedule.png", "csma_cd_network_schedule.png",
                 "can_schedule.png", "can_network_schedule.png", "summary.parquet"):
        assert (tmp_path / name).stat().st_size > 0, name
    by = {(r.network, r.share): r for r in runs.itertuples()}
    for net in ("csma_cd", "can"):
        quiet, loaded = by[(net, 0.0)], by[(net, 0.6)]
        # without interference: 0.2 ms sampling + 1 ms frame + 0.5 ms PID + 1 ms frame + 0.2 ms actuation
        assert quiet.mean_delay == pytest.approx(2.9e-3, abs=1e-12)
        assert quiet.max_delay == pytest.approx(2.9e-3, abs=1e-12)
        assert loaded.mean_delay > 2 * quiet.mean_delay
        assert loaded.cost > 1.2 * quiet.cost
    assert by[("csma_cd", 0.6)].collisions > 0 and by[("can", 0.6)].collisions == 0


def test_networked_servo_rejects_unknown_network():
    with pytest.raises(ValueError, match="token_ring"):
        networked_servo.build("token_ring")
