"""Held-out behaviour: fingerprints of every table the experiments write, to compare a
refactoring against the code before it.

``python -m benchmarks.behaviour record`` runs every experiment in its quick mode
(same seeds as always) into a temporary directory, reads back every Parquet table it
wrote and stores a SHA-256 fingerprint of each table's content (column names, dtypes
and values, bit for bit) in ``benchmarks/behaviour_reference.json``.
``python -m benchmarks.behaviour check`` does the same and compares with the stored
fingerprints, listing every table that differs (exit status 1 if any).

The fingerprints depend on the versions of numpy/scipy/CasADi (floating-point results
of the plant integrators and solvers may change in the last bit between versions), so
compare on one machine: record before the change, check after it.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import sys
import tempfile
import time
from pathlib import Path

#: Experiments fingerprinted (all run with quick=True).
EXPERIMENTS = ["servo", "threeservos", "networked_servo", "ch2_landing", "ch3_fig3_8", "ch3_fig3_10_12", "ch4_fig4_8_9",
               "ch4_fig4_10", "ch5_table5_2", "ch5_fig5_8_9", "gateway", "aodv", "clock_sync", "multicore_dhall",
               "jitterbug_servo", "wireless_tpc", "dvs", "expected_cost_loss",
               "threeservos_cost", "flycrane_cable_break"]
#: Network scenarios fingerprinted beside the experiments (see :func:`network_saturation`).
SCENARIOS = ["network_saturation"]
REFERENCE = Path(__file__).with_name("behaviour_reference.json")
#: A comparison tool, not a timing: ``python -m benchmarks`` skips it.
RUN_WITH_ALL = False


#: Columns that hold wall-clock diagnostics (the solver's own timing of its phases):
#: they differ from run to run and never enter the simulation, so they are left out.
WALL_CLOCK_COLUMNS = ("t_feedback", "t_prepare")


def table_fingerprint(path: Path) -> dict:
    """SHA-256 of a Parquet table's content: columns, dtypes and every value's bytes
    (less the :data:`WALL_CLOCK_COLUMNS`)."""
    import pandas as pd
    df = pd.read_parquet(path)
    df = df.drop(columns=[c for c in WALL_CLOCK_COLUMNS if c in df.columns])
    h = hashlib.sha256()
    h.update(repr(list(df.columns)).encode())
    h.update(repr([str(t) for t in df.dtypes]).encode())
    if len(df):
        h.update(pd.util.hash_pandas_object(df, index=False).to_numpy().tobytes())
    return {"rows": int(len(df)), "sha256": h.hexdigest()}


def network_saturation(outdir, quick: bool = True) -> None:
    """Saturated networks with every trace table written: 802.11b with 10 stations all
    hearing all (shared idle-slot clock and per-station rules), 12 stations on a 10 m
    circle (capture possible), with 20 % frame loss; CAN at 90 % load; 0.3 s each."""
    import math
    import warnings

    from netcosim import Simulation
    from netcosim.network import CAN, MaskedLossWarning, SaturatedSource, WLAN80211b

    from .network import periodic_sender
    out = Path(outdir)
    for label, n, radius, shared, loss in (("wlan_cluster_shared", 10, 0.5, True, 0.0),
                                           ("wlan_cluster_rules", 10, 0.5, False, 0.0),
                                           ("wlan_circle_loss", 12, 10.0, True, 0.2)):
        sim = Simulation(seed=3)
        warnings.filterwarnings("ignore", category=MaskedLossWarning)   # the frame loss is meant
        net = WLAN80211b(sim, "wlan", data_rate=11e6, shared_clock=shared, loss=loss)
        ap = net.attach("ap", position=(0.0, 0.0))
        for i in range(n):
            SaturatedSource(net.attach(f"s{i}", position=(radius * math.cos(i), radius * math.sin(i))), ap, 12_000)
        sim.run(0.3)
        sim.trace.to_parquet(out, prefix=f"{label}_")
    sim = Simulation(seed=3)
    bus = CAN(sim, "can", data_rate=500e3, frame_format="standard")
    sink = bus.attach("sink", priority=10**6)
    rng = sim.rng("phases")
    for i in range(8):
        iface = bus.attach(f"n{i}", priority=i)

        sim.call_at(float(rng.uniform(0, 2.4e-3)), periodic_sender(sim, iface, sink, 2.4e-3))
    sim.run(0.3)
    sim.trace.to_parquet(out, prefix="can_")


def fingerprints(names: list[str]) -> dict:
    """Run each experiment (quick) and fingerprint every Parquet table it writes."""
    out: dict[str, dict] = {}
    for name in names:
        t0 = time.perf_counter()
        run = network_saturation if name == "network_saturation" else \
            importlib.import_module(f"experiments.{name}").main
        with tempfile.TemporaryDirectory() as tmp:
            run(outdir=tmp, quick=True)
            tables = sorted(Path(tmp).rglob("*.parquet"))
            out[name] = {str(p.relative_to(tmp)): table_fingerprint(p) for p in tables}
        print(f"{name}: {len(out[name])} tables ({time.perf_counter() - t0:.1f} s)", flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("action", choices=["record", "check"])
    ap.add_argument("--only", nargs="+", metavar="NAME", help="experiments to run (default: all)")
    ap.add_argument("--reference", type=Path, default=REFERENCE, help="fingerprint file")
    a = ap.parse_args(argv)
    names = a.only or EXPERIMENTS + SCENARIOS
    got = fingerprints(names)
    if a.action == "record":
        old = json.loads(a.reference.read_text()) if a.reference.exists() else {}
        old.update(got)
        a.reference.write_text(json.dumps(old, indent=1, sort_keys=True) + "\n")
        print(f"-> {a.reference}")
        return 0
    ref = json.loads(a.reference.read_text())
    bad = []
    for name, tables in got.items():
        want = ref.get(name)
        if want is None:
            bad.append(f"{name}: no reference recorded")
            continue
        for t in sorted(set(want) | set(tables)):
            if want.get(t) != tables.get(t):
                bad.append(f"{name}/{t}: reference {want.get(t)} != now {tables.get(t)}")
    for line in bad:
        print("DIFFERS", line)
    print(f"{sum(len(t) for t in got.values())} tables compared, {len(bad)} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
