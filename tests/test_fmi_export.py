"""The network exported as an FMI 2.0 co-simulation FMU (pythonfmu), driven by FMPy: the
same delays and losses as the network simulated natively, message for message, for a
fixed seed; the command line ``netcosim export-fmu``; bad arguments.

FMPy drives each FMU in a process of its own, as an orchestrator would: pythonfmu's runtime
embeds Python, and a second instance of such an FMU in one Python process (after the first
was freed) does not instantiate.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("fmpy", reason="FMPy (pip install 'netcosim[fmi]') is not installed")
pytest.importorskip("pythonfmu", reason="pythonfmu is not installed")

from fmu_networks import ethernet  # noqa: E402

from netcosim import Simulation  # noqa: E402
from netcosim.cli import main  # noqa: E402
from netcosim.errors import ConfigurationError  # noqa: E402
from netcosim.fmi.export import export_network_fmu  # noqa: E402

NODES = ["a", "b", "c"]
STEP = 1e-4          # communication step of the orchestrator (s)
SEND_EVERY = 30      # steps between two rounds of messages (3 ms)
ROUNDS = 20
STEPS = 1000         # 0.1 s


def schedule():
    """(step index, sender, tag, destination index, payload): each station sends one message
    to the next station every 3 ms, all three at the same instant (collisions)."""
    out = []
    for r in range(ROUNDS):
        for i, n in enumerate(NODES):
            seq = 3 * r + i + 1
            out.append((r * SEND_EVERY, n, seq, (i + 1) % 3, 0.5 * seq))
    return out


def native(seed):
    """{(receiver, tag): (sender, payload, delay)} of the network run natively."""
    sim = Simulation(seed=seed)
    net = ethernet(sim)
    got = {}
    for n in NODES:
        net.interfaces[n].on_receive(lambda msg, n=n: got.__setitem__(
            (n, msg.payload[0]), (msg.src, msg.payload[1], msg.delivered - msg.created)))
    for k, n, seq, dst, value in schedule():
        sim.call_at(k * STEP, lambda n=n, seq=seq, dst=dst, value=value:
                    net.interfaces[n].send(NODES[dst], (seq, value), 256))
    sim.run(STEPS * STEP)
    return got


def through_fmpy(path, seed):
    """The same traffic through the FMU, stepped by FMPy every STEP s (in another process)."""
    here = Path(__file__).resolve().parent
    # os._exit after the output: pythonfmu's embedded interpreter can corrupt the heap while the
    # host Python exits (seen once in a fresh clone's suite, after the FMU was freed and the
    # results printed); what is checked here is the FMU's run, which has ended by then
    code = ("import json, os, sys; sys.path.insert(0, sys.argv[1]); import test_fmi_export as t; "
            "print(json.dumps([[k[0], k[1], *v] for k, v in t.drive(sys.argv[2], int(sys.argv[3])).items()]), "
            "flush=True); os._exit(0)")
    out = subprocess.run([sys.executable, "-c", code, str(here), str(path), str(seed)], capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return {(r[0], r[1]): (r[2], r[3], r[4]) for r in json.loads(out.stdout.splitlines()[-1])}


def drive(path, seed):
    """The traffic of :func:`schedule` through the FMU at *path*, stepped by FMPy every STEP s:
    {(receiver, tag): (sender, payload, delay)}."""
    import fmpy
    from fmpy.fmi2 import FMU2Slave
    md = fmpy.read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="net")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setInteger([vr["seed"]], [seed])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    sends = {}
    for k, n, seq, dst, value in schedule():
        sends.setdefault(k, []).append((n, seq, dst, value))
    got, counts = {}, {n: 0 for n in NODES}
    for k in range(STEPS):
        for n, seq, dst, value in sends.get(k, []):
            fmu.setInteger([vr[f"{n}.tx_seq"], vr[f"{n}.tx_dst"]], [seq, dst])
            fmu.setReal([vr[f"{n}.tx_value"]], [value])
        fmu.doStep(k * STEP, STEP)
        for n in NODES:
            count, seq, src = fmu.getInteger([vr[f"{n}.rx_count"], vr[f"{n}.rx_seq"], vr[f"{n}.rx_src"]])
            assert count - counts[n] <= 1, "two deliveries within one step: step finer"
            if count > counts[n]:
                value, delay = fmu.getReal([vr[f"{n}.rx_value"], vr[f"{n}.rx_delay"]])
                got[(n, seq)] = (NODES[src], value, delay)
            counts[n] = count
    fmu.terminate()
    fmu.freeInstance()
    return got


@pytest.fixture(scope="module")
def network_fmu(tmp_path_factory):
    return export_network_fmu("fmu_networks:ethernet", NODES, tmp_path_factory.mktemp("export") / "lan.fmu",
                              seed=3, size_bits=256)


@pytest.mark.parametrize("seed", [3, 11])
def test_the_exported_network_reproduces_the_native_run_message_for_message(network_fmu, seed):
    want = native(seed)
    got = through_fmpy(network_fmu, seed)
    sent = {(NODES[dst], seq) for _, _, seq, dst, _ in schedule()}
    lost = sent - set(want)
    assert 0 < len(lost) < len(sent) // 2          # the 20 % loss shows, most messages arrive
    assert len({round(d, 9) for _, _, d in want.values()}) > 5      # contention: the delays vary
    assert got == want                              # same messages, same payloads, same delays (exactly)
    assert sent - set(got) == lost


def test_different_seeds_give_different_losses():
    assert set(native(3)) != set(native(11))


def test_the_command_line_exports_the_same_fmu(tmp_path, capsys):
    out = tmp_path / "cli.fmu"
    assert main(["export-fmu", "fmu_networks:link", "--nodes", "a,b", "--out", str(out), "--seed", "5"]) == 0
    assert f"wrote {out}" in capsys.readouterr().out
    import fmpy
    md = fmpy.read_model_description(str(out))
    names = {v.name: v for v in md.modelVariables}
    assert {"seed", "a.tx_seq", "b.rx_delay", "b.rx_count"} <= set(names)
    assert names["seed"].start == "5" and names["a.tx_seq"].causality == "input"
    # the ideal link: a 256-bit message at 1 Mbit/s arrives after 256 us
    code = ("import sys, fmpy, numpy as np; r = fmpy.simulate_fmu(sys.argv[1], stop_time=0.001, step_size=1e-5, "
            "output=['b.rx_count', 'b.rx_delay'], input=np.array([(0.0, 1, 1), (1.0, 1, 1)], "
            "dtype=[('time', float), ('a.tx_seq', int), ('a.tx_dst', int)])); "
            "print(r['b.rx_count'][-1], repr(float(r['b.rx_delay'][-1])), flush=True); "
            "import os; os._exit(0)")      # see through_fmpy: the host's exit is not what is tested
    run = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    count, delay = run.stdout.split()[-2:]
    assert int(count) == 1 and float(delay) == pytest.approx(256e-6, abs=1e-12)


def test_bad_exports_are_named(tmp_path):
    with pytest.raises(ConfigurationError, match=r"no station 'd' \(stations: \['a', 'b', 'c'\]\)"):
        export_network_fmu("fmu_networks:ethernet", ["a", "d"], tmp_path / "x.fmu")
    with pytest.raises(ConfigurationError, match=r"network builder 'fmu_networks:nothing'.*has no function"):
        export_network_fmu("fmu_networks:nothing", ["a"], tmp_path / "x.fmu")
    with pytest.raises(ConfigurationError, match=r"FMU name must be a Python identifier, got 'my net'"):
        export_network_fmu("fmu_networks:link", ["a"], tmp_path / "x.fmu", name="my net")
    with pytest.raises(ConfigurationError, match=r"must end in \.fmu"):
        export_network_fmu("fmu_networks:link", ["a"], tmp_path / "x.zip")


def test_the_command_line_names_a_bad_builder(tmp_path, capsys):
    assert main(["export-fmu", "fmu_networks:nothing", "--nodes", "a", "--out", str(tmp_path / "x.fmu")]) == 2
    assert "has no function 'nothing'" in capsys.readouterr().err
