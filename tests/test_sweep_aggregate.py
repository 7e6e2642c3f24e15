"""netcosim.sweep.aggregate: medians and quantile bands across seeds on a synthetic runs
table; diverged and failed runs are counted, never aggregated."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from netcosim.errors import ConfigurationError, ConfigurationTypeError  # noqa: E402
from netcosim.sweep.aggregate import SUMMARY_COLUMNS, plot_sweep, summarize  # noqa: E402


def runs() -> pd.DataFrame:
    """2 losses x 2 strategies x 5 seeds in the runs-table layout.

    loss 0.0, a: J = 1, 2, 3, 4, 5                      -> median 3, quartiles 2, 4
    loss 0.0, b: J = 10, 20, 30, 1e16 (diverged), 40    -> over 10..40: 25, 17.5, 32.5
    loss 0.5, a: J = 2, 4, NaN (error), inf, 8           -> over 2, 4, 8: 4, 3, 6
    loss 0.5, b: all diverged                            -> NaN
    """
    rows = []
    table = {
        (0.0, "a"): [(1, False, "ok"), (2, False, "ok"), (3, False, "ok"), (4, False, "ok"), (5, False, "ok")],
        (0.0, "b"): [(10, False, "ok"), (20, False, "ok"), (30, False, "ok"), (1e16, True, "ok"), (40, False, "ok")],
        (0.5, "a"): [(2, False, "ok"), (4, False, "ok"), (np.nan, np.nan, "error"), (np.inf, False, "ok"),
                     (8, False, "ok")],
        (0.5, "b"): [(1e16, True, "ok"), (3e17, True, "ok"), (np.nan, True, "ok"), (1e20, True, "timeout"),
                     (5e16, True, "ok")],
    }
    for (loss, strategy), cases in table.items():
        for i, (J, div, status) in enumerate(cases):
            rows.append({"loss": loss, "strategy": strategy, "seed_index": i, "seed": 100 + i, "J": J,
                         "diverged": div, "status": status, "error": "" if status == "ok" else "boom",
                         "traceback": "", "wall_time": 0.1})
    return pd.DataFrame(rows)


def test_summary_counts_and_statistics():
    s = summarize(runs(), "loss", "J", hue="strategy")
    assert list(s.columns) == ["loss", "strategy", *SUMMARY_COLUMNS]
    assert s[["loss", "strategy"]].values.tolist() == [[0.0, "a"], [0.0, "b"], [0.5, "a"], [0.5, "b"]]
    assert s["n"].tolist() == [5, 5, 5, 5]
    assert s["n_failed"].tolist() == [0, 0, 1, 1]
    # loss 0.5 a: the inf counts as diverged though its flag is False; the failed run does not count twice
    assert s["n_diverged"].tolist() == [0, 1, 1, 4]
    assert s["n_used"].tolist() == [5, 4, 3, 0]
    np.testing.assert_allclose(s["median"], [3.0, 25.0, 4.0, np.nan])
    np.testing.assert_allclose(s["q_low"], [2.0, 17.5, 3.0, np.nan])
    np.testing.assert_allclose(s["q_high"], [4.0, 32.5, 6.0, np.nan])
    assert s["median"].max() < 1e15        # no 1e16 leaks into any statistic


def test_summary_without_hue_and_other_quantiles():
    s = summarize(runs(), "loss", "J", quantiles=(0.1, 0.9))
    assert list(s.columns) == ["loss", *SUMMARY_COLUMNS]
    assert s["n"].tolist() == [10, 10]
    used0 = [1, 2, 3, 4, 5, 10, 20, 30, 40]
    assert s["median"].iloc[0] == 5.0
    assert s["q_low"].iloc[0] == pytest.approx(np.quantile(used0, 0.1))
    assert s["q_high"].iloc[0] == pytest.approx(np.quantile(used0, 0.9))
    assert s["median"].iloc[1] == 4.0


def test_summary_without_flag_or_status_columns():
    df = runs().drop(columns=["diverged", "status"])
    s = summarize(df, "loss", "J", "strategy", diverged=None)
    # without flags only non-finite J is diverged; 1e16 is then an ordinary (huge) value
    assert s["n_failed"].tolist() == [0, 0, 0, 0]
    assert s["n_diverged"].tolist() == [0, 0, 2, 1]
    assert s["median"].iloc[1] == 30.0


@pytest.mark.parametrize("kwargs, err, match", [
    (dict(x="rate"), ConfigurationError, r"x='rate' is not a column.*'loss'"),
    (dict(y="cost"), ConfigurationError, r"y='cost' is not a column"),
    (dict(hue="mode"), ConfigurationError, r"hue='mode' is not a column"),
    (dict(hue="loss"), ConfigurationError, r"hue='loss' is the same column as x"),
    (dict(diverged="blown"), ConfigurationError, r"diverged='blown'.*diverged=None"),
    (dict(quantiles=(0.75, 0.25)), ConfigurationError, r"low <= high.*\(0\.75, 0\.25\)"),
    (dict(quantiles=(0.25, 1.5)), ConfigurationError, r"quantiles: high.*1\.5"),
    (dict(quantiles=0.5), ConfigurationTypeError, r"pair.*0\.5"),
    (dict(y="status"), ConfigurationTypeError, r"y='status' must be numeric; row 0 holds 'ok'"),
])
def test_bad_input_names_the_value(kwargs, err, match):
    args = dict(x="loss", y="J", hue="strategy") | kwargs
    with pytest.raises(err, match=match):
        summarize(runs(), **args)


def test_plot_sweep_draws_medians_bands_and_counts():
    ax = plot_sweep(runs(), x="loss", y="J", hue="strategy")
    lines = ax.get_lines()
    assert len(lines) == 2
    np.testing.assert_allclose(lines[0].get_ydata(), [3.0, 4.0])
    np.testing.assert_allclose(lines[1].get_ydata(), [25.0, np.nan])
    assert len(ax.collections) == 2                      # one band per strategy
    texts = sorted(t.get_text() for t in ax.texts)
    assert texts == ["1 div", "1 div, 1 fail", "4 div, 1 fail"]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["strategy=a (diverged 1/10, failed 1)", "strategy=b (diverged 5/10, failed 1)"]
    assert ax.get_xlabel() == "loss"
    lo, hi = ax.get_xlim()
    assert lo < 0.0 and hi > 0.5                         # loss 0.5 stays in view though b has no median there


def test_plot_sweep_on_given_axes_without_hue():
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    assert plot_sweep(runs(), hue=None, ax=ax, logy=True) is ax
    assert ax.get_yscale() == "log"
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), [5.0, 4.0])
    plt.close(fig)


def _no_divergence_flag(params, seed):
    return {"J": params["loss"] * 10 + seed % 3}


def test_sweep_result_plots_a_scenario_that_returns_no_diverged_column(tmp_path):
    from netcosim.sweep import run_sweep
    res = run_sweep(_no_divergence_flag, {"loss": [0.0, 0.5], "mode": ["a", "b"]}, seeds=3, executor="serial",
                    quiet=True)
    assert "diverged" not in res.runs.columns
    ax = res.plot(y="J", hue="mode")
    assert len(ax.get_lines()) >= 2
    with pytest.raises(ConfigurationError, match="diverged='diverged' is not a column"):
        res.plot(y="J", hue="mode", diverged="diverged")
