"""Clock synchronisation: two-way time transfer (NTP/PTP style) between drifting node clocks.

A ``server`` node and two clients run on local clocks (``sim.node(..., clock_offset=,
clock_drift=)``: offsets of milliseconds, drifts of tens of ppm).  Every ``T_sync`` s of
its own clock a client's task stamps t1 and sends a request; the server's task stamps t2
when it runs on the request's arrival and t3 just before it replies; the client's task
stamps t4 when the reply arrives and estimates

    offset = ((t2 - t1) + (t3 - t4)) / 2,      delay = (t4 - t1) - (t3 - t2),

then corrects its clock by the offset: a step (``ctx.clock.step``, as ``ntpdate``) or a
slew over half a sync period (``ctx.clock.adjust``, as ``adjtime``).  All stamps are
``ctx.now`` (local time); the residual offset, client minus server reading, is read
from the clocks themselves (``node.clock.local(t)``) every millisecond of simulation time.

Analytic bound, after the first correction has taken effect: between two syncs the
residual grows by |drift_c - drift_s|·T_sync (the clocks' rates differ by that); a
delay asymmetry a (the request leaves a s after its t1 stamp: d_up - d_down = a) biases
every estimate by a/2 (the client ends up a/2 ahead of the server), so

    |residual| <= |drift_c - drift_s|·T_sync + |a|/2  (+ the drift during one exchange
    and the delay jitter of the network, which an ideal link does not have).

The example runs the exchange on 802.11b with step and slew corrections (the stamps are
taken by tasks, not by the radio, so each exchange's random backoff, up to hundreds of
µs, is an asymmetry of its own: the residual is dominated by it), then on an ideal
link: the largest residual against the bound for several sync periods, and the bias
against +a/2 for several asymmetries.  The steady state starts after the second
correction (the first removes the initial milliseconds and, as a step, moves the next
request by as much).

Run: ``python -m netcosim.experiments.clock_sync`` (PNG + Parquet under results/clock_sync/).
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import pandas as pd

from netcosim import IdealLink, Simulation, WLAN80211b
from netcosim.timebase import TICKS_PER_SECOND

#: the reference clock: offset (s) and drift (dimensionless)
SERVER = {"offset": 1e-3, "drift": 20e-6}
#: the clients' clocks
CLIENTS = {"c1": {"offset": -4e-3, "drift": -30e-6}, "c2": {"offset": 2.5e-3, "drift": 50e-6}}
FRAME_BITS = 256            # bits per request or reply
SERVER_EXEC = 50e-6         # CPU time (s) between the server's t2 and t3
FIRST_SYNC = 0.1            # local time (s) of the first client's first request, after its creation
STAGGER = 0.3               # the next client's first request: this fraction of T_sync later


def bound(drift_client: float, drift_server: float, sync_period: float, asymmetry: float = 0.0) -> float:
    """The analytic bound (s) on the residual offset between syncs: ``|Δdrift|·T_sync + |a|/2``."""
    return abs(drift_client - drift_server) * sync_period + abs(asymmetry) / 2


def build(*, network: str = "wlan", sync_period: float = 1.0, asymmetry: float = 0.0, correction: str = "step",
          clients: dict | None = None, server: dict | None = None, sample: float = 1e-3, seed: int = 0):
    """The scenario: ``(sim, nodes, record)``; ``record`` collects ``residual`` rows
    ``(t, client, client minus server reading)`` (s) every *sample* s and ``syncs`` rows
    ``(t, client, offset estimate, delay estimate)``.

    ``network``: ``"wlan"`` (802.11b, 11 Mbit/s) or ``"ideal"`` (1 Mbit/s, 50 µs);
    ``correction``: ``"step"`` or ``"slew"`` (over ``sync_period / 2``); ``asymmetry``
    (s, >= 0): the client sends its request that long after stamping t1.
    """
    if correction not in ("step", "slew"):
        raise ValueError(f"correction must be 'step' or 'slew', got {correction!r}")
    if not asymmetry >= 0:
        raise ValueError(f"asymmetry must be >= 0 s, got {asymmetry!r}")
    clients = CLIENTS if clients is None else clients
    server = SERVER if server is None else server
    sim = Simulation(seed=seed)
    if network == "wlan":
        net = WLAN80211b(sim, "net", data_rate=11e6)
    elif network == "ideal":
        net = IdealLink(sim, "net", data_rate=1e6, delay=50e-6)
    else:
        raise ValueError(f"network must be 'wlan' or 'ideal', got {network!r}")
    where = (lambda i: {"position": (10.0 * i, 0.0)}) if network == "wlan" else (lambda i: {})
    srv = sim.node("server", clock_offset=server["offset"], clock_drift=server["drift"])
    s_if = net.attach(srv, **where(0))
    record: dict[str, list] = {"residual": [], "syncs": []}

    @srv.aperiodic(priority=1, name="stamp")
    def stamp(ctx):
        msg = yield s_if.mailbox.fetch()
        t2 = ctx.now
        yield ctx.execute(SERVER_EXEC)
        t3 = ctx.now
        ctx.send(msg.src, payload=(msg.payload, t2, t3), size_bits=FRAME_BITS)
    s_if.on_receive(stamp)

    nodes = {"server": srv}
    for i, (name, spec) in enumerate(clients.items(), start=1):
        node = sim.node(name, clock_offset=spec["offset"], clock_drift=spec["drift"])
        c_if = net.attach(node, **where(i))
        nodes[name] = node

        def request(ctx):
            t1 = ctx.now
            if asymmetry:
                yield ctx.sleep(asymmetry)
            ctx.send("server", payload=t1, size_bits=FRAME_BITS)
        node.periodic(request, period=sync_period, offset=FIRST_SYNC + STAGGER * (i - 1) * sync_period, priority=2,
                      name="request")

        def correct(ctx, c_if=c_if, name=name):
            msg = yield c_if.mailbox.fetch()
            t4 = ctx.now
            t1, t2, t3 = msg.payload
            offset = ((t2 - t1) + (t3 - t4)) / 2
            delay = (t4 - t1) - (t3 - t2)
            record["syncs"].append((ctx.sim.now, name, offset, delay))
            if correction == "step":
                ctx.clock.step(offset)
            else:
                ctx.clock.adjust(offset, over=sync_period / 2)
        c_if.on_receive(node.aperiodic(correct, priority=1, name="correct"))

    step = round(sample * TICKS_PER_SECOND)
    reference = srv.clock

    def observe(k: int = 0) -> None:
        g = k * step
        ls = reference.local_ticks(g)
        for name in clients:
            diff = nodes[name].clock.local_ticks(g) - ls
            record["residual"].append((g / TICKS_PER_SECOND, name, float(Fraction(diff) / TICKS_PER_SECOND)))
        sim.call_at_ticks((k + 1) * step, lambda: observe(k + 1))
    sim.call_at(0.0, observe)
    return sim, nodes, record


def run(until: float, **kw) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Run :func:`build` for *until* s: ``(residual, syncs)`` tables (s)."""
    sim, _, record = build(**kw)
    sim.run(until)
    return (pd.DataFrame(record["residual"], columns=["time", "client", "residual"]),
            pd.DataFrame(record["syncs"], columns=["time", "client", "offset", "delay"]))


def settled(residual: pd.DataFrame, syncs: pd.DataFrame, sync_period: float, correction: str,
            skip: int = 1) -> pd.DataFrame:
    """The residual rows once each client's correction number *skip* (0: the first) has
    taken effect (its reply, plus the slew's length for a slew).  The first correction
    removes the initial offset of milliseconds; a step of that size also moves the next
    request by as much, so the steady state starts after the second."""
    start = syncs.groupby("client")["time"].nth(skip)
    start = pd.Series(start.to_numpy(), index=syncs.loc[start.index, "client"].to_numpy())
    lag = sync_period / 2 if correction == "slew" else 0.0
    keep = residual["time"] > residual["client"].map(start).fillna(float("inf")) + lag + 1e-3
    return residual[keep]


def summary(residual: pd.DataFrame, syncs: pd.DataFrame, *, sync_period: float, asymmetry: float,
            correction: str, clients: dict | None = None, server: dict | None = None) -> pd.DataFrame:
    """Per client, in the steady state (after the second correction): the largest
    |residual|, the analytic bound, the mean residual 1 ms after each correction took
    effect (the bias, about +a/2), the largest delay estimate (s)."""
    clients = CLIENTS if clients is None else clients
    server = SERVER if server is None else server
    after = settled(residual, syncs, sync_period, correction)
    lag = (sync_period / 2 if correction == "slew" else 0.0) + 1e-3
    rows = []
    for name, spec in clients.items():
        r = after[after["client"] == name].set_index("time")["residual"]
        mine = syncs[syncs["client"] == name]
        times = mine["time"].to_numpy()[1:] + lag
        just = [r.iloc[r.index.get_indexer([t], method="bfill")[0]] for t in times if len(r) and t < r.index.max()]
        rows.append({"client": name, "sync_period": sync_period, "asymmetry": asymmetry, "correction": correction,
                     "max_abs_residual": float(r.abs().max()) if len(r) else float("nan"),
                     "bound": bound(spec["drift"], server["drift"], sync_period, asymmetry),
                     "bias": float(pd.Series(just).mean()) if just else float("nan"),
                     "max_delay": float(mine["delay"].max()), "syncs": len(mine)})
    return pd.DataFrame(rows)


def main(outdir: str = "results/clock_sync", quick: bool = False) -> pd.DataFrame:
    """Residual offset over time (802.11b, step and slew), then on an ideal link the
    largest residual against the bound for several sync periods and the bias against
    +a/2 for several asymmetries.  Writes ``clock_sync.png`` and ``summary.parquet``;
    returns the summary table (s)."""
    import matplotlib.pyplot as plt

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    until = 6.0 if quick else 20.0
    periods = (0.5, 1.0) if quick else (0.25, 0.5, 1.0, 2.0)
    asymmetries = (0.0, 1e-3) if quick else (0.0, 0.5e-3, 1e-3, 2e-3)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    rows = []
    for correction, style in (("step", "-"), ("slew", "--")):
        print(f"  802.11b, {correction}, T_sync = 1 s: {until} s", flush=True)
        residual, syncs = run(until, network="wlan", correction=correction)
        rows.append(summary(residual, syncs, sync_period=1.0, asymmetry=0.0, correction=correction).assign(
            network="wlan"))
        after = settled(residual, syncs, 1.0, correction, skip=0)
        for name, g in after.groupby("client"):
            axes[0].plot(g["time"], g["residual"] * 1e6, style, lw=1, label=f"{name}, {correction}")
    for name, spec in CLIENTS.items():
        b = bound(spec["drift"], SERVER["drift"], 1.0) * 1e6
        axes[0].axhline(b, color="grey", lw=0.6)
        axes[0].axhline(-b, color="grey", lw=0.6)
    axes[0].set_title("T_sync = 1 s: residual (client − server), 802.11b and an ideal link\n"
                      "grey: ±|Δdrift|·T_sync; 802.11b: the reply backs off (bias) at random (jitter)", fontsize=9)
    axes[0].set_xlabel("simulation time [s]")
    axes[0].set_ylabel("residual [µs]  (grey: ±|Δdrift|·T_sync)")
    for T in periods:
        print(f"  ideal link, step, T_sync = {T} s", flush=True)
        residual, syncs = run(until, network="ideal", sync_period=T, sample=min(1e-3, T / 50))
        rows.append(summary(residual, syncs, sync_period=T, asymmetry=0.0, correction="step").assign(
            network="ideal"))
        if T == 1.0:
            for name, g in settled(residual, syncs, 1.0, "step", skip=0).groupby("client"):
                axes[0].plot(g["time"], g["residual"] * 1e6, ":", lw=1.2, label=f"{name}, step, ideal link")
    axes[0].legend(fontsize=6, ncol=2)
    for a in asymmetries:
        print(f"  ideal link, step, asymmetry {a * 1e3} ms", flush=True)
        residual, syncs = run(until, network="ideal", asymmetry=a)
        rows.append(summary(residual, syncs, sync_period=1.0, asymmetry=a, correction="step").assign(
            network="ideal"))
    table = pd.concat(rows, ignore_index=True)
    ideal = table[(table["network"] == "ideal") & (table["asymmetry"] == 0.0)].drop_duplicates(
        ["client", "sync_period"])
    for name, g in ideal.groupby("client"):
        g = g.sort_values("sync_period")
        line, = axes[1].plot(g["sync_period"], g["max_abs_residual"] * 1e6, "o", label=f"{name}: measured")
        axes[1].plot(g["sync_period"], g["bound"] * 1e6, "-", color=line.get_color(), label=f"{name}: bound")
    axes[1].set_title("ideal link: largest |residual| vs sync period")
    axes[1].set_xlabel("T_sync [s]")
    axes[1].set_ylabel("max |residual| [µs]")
    axes[1].legend(fontsize=7)
    asym = table[(table["network"] == "ideal") & (table["sync_period"] == 1.0)].drop_duplicates(
        ["client", "asymmetry"])
    for name, g in asym.groupby("client"):
        g = g.sort_values("asymmetry")
        axes[2].plot(g["asymmetry"] * 1e3, g["bias"] * 1e6, "o-", label=f"{name}: mean residual after sync")
    xs = sorted(asym["asymmetry"].unique())
    axes[2].plot([x * 1e3 for x in xs], [x / 2 * 1e6 for x in xs], "k:", label="a/2")
    axes[2].set_title("ideal link: bias vs delay asymmetry a")
    axes[2].set_xlabel("a [ms]")
    axes[2].set_ylabel("bias [µs]")
    axes[2].legend(fontsize=7)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "clock_sync.png", dpi=120)
    plt.close(fig)
    table.to_parquet(out / "summary.parquet")
    shown = table.assign(max_abs_residual_us=table["max_abs_residual"] * 1e6, bound_us=table["bound"] * 1e6,
                         bias_us=table["bias"] * 1e6, asymmetry_ms=table["asymmetry"] * 1e3)
    print(shown[["network", "correction", "client", "sync_period", "asymmetry_ms", "max_abs_residual_us", "bound_us",
                 "bias_us"]].to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/clock_sync",
                          quick="6 s runs, two sync periods and two asymmetries (instead of 20 s, four of each)"
                          ).parse_args()
    main(a.outdir, a.quick)
