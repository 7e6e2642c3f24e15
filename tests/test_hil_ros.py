"""The ROS 2-friendly encoding end to end: the networked servo's controller in a process
that speaks CDR (pycdr2, an independent implementation) on rmw_zenoh-style keys, learns
the keys and the session through the info query, and checks rmw_zenoh's attachment on
every request.  Skipped without Zenoh or pycdr2."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_every_request_accounted

from netcosim.transport.session import zenoh_available

pytestmark = pytest.mark.skipif(not zenoh_available(), reason="the zenoh extra (eclipse-zenoh) is not installed")
REMOTE = Path(__file__).resolve().parent / "hil_ros_remote.py"


def test_servo_over_cdr_with_an_independent_ros_style_client():
    pytest.importorskip("pycdr2", reason="pycdr2 (Cyclone DDS's IDL/CDR package) is not installed")
    from netcosim.experiments import hil_servo as hs
    from netcosim.transport import cdr
    run = hs.run_hil(1.0, program=[sys.executable, str(REMOTE)], encoding="cdr", deadline=0.1)
    c = run.remote.counters()
    assert run.failure is None
    assert_every_request_accounted(c, 100, process=run.process)
    p = run.process
    assert p["status"] == "ended" and p["attachments"] >= c["published"] + 1     # requests and END
    # the keys the process was handed are rmw_zenoh's: domain 0, topic, type name, type hash
    rx = p["info"]["keys"]["rx"]
    assert rx == cdr.ros_key(run.remote.run_id, "controller", "rx") and rx.startswith(
        f"0/netcosim/{run.remote.run_id}/controller/rx/netcosim_msgs::msg::dds_::Frame_/RIHS01_")
    assert p["info"]["encoding"] == "cdr"
    assert p["info"]["network"] == {"sensor": 0, "controller": 1, "interferer": 2, "sink": 3}
    assert p["info"]["schema"] == hs.SCHEMA
    y = run.output()["value"].to_numpy()
    replay = hs.servo_output(hs.run_replay(1.0, run.remote.requests()))["value"].to_numpy()
    assert np.array_equal(y, replay)


def test_an_encoding_nobody_speaks_is_refused():
    from netcosim.errors import ConfigurationError
    from netcosim.transport.client import RemoteProcess
    from netcosim.transport.codecs import codec
    with pytest.raises(ValueError, match="encoding must be one of .*'json'"):
        codec("json")
    with pytest.raises(ValueError, match="encoding must be one of"):
        RemoteProcess("x", run="r1", connect=[], encoding="json")
    from netcosim import Simulation
    from netcosim.experiments import networked_servo
    sim, _ = networked_servo.build("csma_cd", 0.0)
    from netcosim.transport.remote import RemoteNode
    with pytest.raises(ConfigurationError, match="encoding must be one of"):
        RemoteNode(sim, "controller", object(), run="r1", size_bits=80, period=0.01, encoding="json")
    del Simulation
