"""Figs. 3.10-3.12: the LAAS rig of Sec. 3.6 in simulation (dynamic model, lossy 802.11b).

The claims are the thesis's description of the measured runs (Sec. 3.6, text around
Figs. 3.10-3.12); quick mode (5 s per waypoint) by default, the full run with ``-m slow``."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from netcosim.errors import ConfigurationError

QUICK = pytest.mark.parametrize("quick", [True, pytest.param(False, marks=pytest.mark.slow)])
#: Largest ||q - q^r|| (rad and m) the online run leaves at the end of a waypoint's
#: interval: quick (5 s per waypoint) and full (10 s).
ONLINE_TOL = {True: 0.05, False: 0.005}


@QUICK
def test_rig_reproduces_the_measured_behaviour(tmp_path, quick):
    from netcosim.experiments import ch3_fig3_10_12 as ex
    summary = ex.main(outdir=str(tmp_path), quick=quick)
    for n in ("fig3_10.png", "fig3_11.png", "fig3_12.png", "series.parquet", "samples.parquet", "summary.parquet"):
        assert (tmp_path / n).stat().st_size > 0, n
    s = summary.set_index(["strategy", "waypoint"])
    off, on = s.loc["offline"], s.loc["online"]
    assert len(off) == len(on) == 4
    # each switch is a step of 0.3 m (lift, move) or more (rotation, final configuration)
    assert (on.err_start > 0.25).all()
    # both converge to every waypoint (offline: exponentially, Prop. 3.4.5) ...
    assert (on.err_end < ONLINE_TOL[quick]).all()
    assert (off.err_end < 0.5 * off.err_start).all()
    # ... "the on-line strategy allows to converge to the desired configurations much
    # faster with respect to the off-line technique" (Fig. 3.10)
    assert (on.err_end < off.err_end / 3).all()
    # "the desired velocities generated with the on-line technique are larger" (Fig. 3.11)
    assert (on.max_speed > 1.1 * off.max_speed).all()
    samples = pd.read_parquet(tmp_path / "samples.parquet")
    tau_on = samples[samples.strategy == "online"].groupby("h").tau_o.first()
    tau_off = samples[samples.strategy == "offline"].tau_o
    # Fig. 3.12: the offline flow time is the constant tau_o_bar(mu_hat) (3.23) below 1;
    # the online one is larger at every sample, and "tau_0 -> 1, k_h -> 1/T as q -> q^r"
    assert tau_off.nunique() == 1 and tau_off.iloc[0] < 1.0
    assert (tau_on > tau_off.iloc[0]).all()
    assert tau_on.iloc[-1] == pytest.approx(1.0, abs=0.01)
    # "piece-wise constant signals with a period of T": the offline commands (held on a
    # loss) change only in the grid step after a sampling instant hT
    series = pd.read_parquet(tmp_path / "series.parquet")
    d = series[series.strategy == "offline"]
    u = d.filter(regex=r"^u\d+$").values
    changed = d.t.values[1:][np.any(u[1:] != u[:-1], axis=1)]
    phase = np.mod(changed + 1e-9, ex.T)
    assert len(changed) > 0 and (phase <= ex.SAMPLE_DT + 1e-6).all()


def test_rig_is_deterministic_and_the_link_loses_frames():
    from netcosim.experiments import ch3_fig3_10_12 as ex
    a, _ = ex.simulate("online", 0.3, period=1.5, loss=0.3, seed=4)
    b, _ = ex.simulate("online", 0.3, period=1.5, loss=0.3, seed=4)
    pd.testing.assert_frame_equal(a, b)
    c, _ = ex.simulate("online", 0.3, period=1.5, loss=0.0, seed=4)
    assert not np.array_equal(a.filter(like="u").values, c.filter(like="u").values)


def test_rig_rejects_bad_input():
    from netcosim.experiments import ch3_fig3_10_12 as ex
    with pytest.raises(ConfigurationError, match="loss"):
        ex.run(quick=True, loss=1.5)
    with pytest.raises(ConfigurationError, match="strategy"):
        ex.simulate("fast", 0.3, period=1.5)
    with pytest.raises(ConfigurationError, match="waypoint period"):
        ex.simulate("online", 0.3, period=0.0)
