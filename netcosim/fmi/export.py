"""Export a netcosim network (optionally with kernels) as an FMI 2.0 co-simulation FMU.

:func:`export_network_fmu` packages the network a builder function makes, ``fn(sim) ->
network`` (it may also add kernel nodes and tasks to *sim*), as an FMU whose inputs are
messages to send and whose outputs are the delivered messages with their delays (the port
mapping is in :mod:`netcosim.fmi.network_slave`).  An orchestrator (FMPy, OMSimulator,
Maestro, Simulink) then uses the project's network models as one more FMU.

pythonfmu builds the FMU: it is the well-kept tool for FMUs written in Python, and an FMI
2.0 co-simulation FMU is what every orchestrator reads.  The FMU runs netcosim in the
Python interpreter pythonfmu embeds: netcosim (and numpy, SimPy, ...) must be installed in
that Python.  A builder defined in a top-level module (one file) is copied into the FMU;
a builder in a package must be importable where the FMU runs.
"""

from __future__ import annotations

import inspect
import json
import keyword
import sys
import tempfile
from pathlib import Path
from typing import Any, Sequence

from .. import validate
from ..errors import ConfigurationError

__all__ = ["export_network_fmu"]


def export_network_fmu(builder: str, nodes: Sequence[str], path: Any, *, seed: int = 0, size_bits: int = 256,
                       name: str = "NetcosimNetwork") -> Path:
    """Write the FMU of the network ``builder(sim)`` with stations *nodes* to *path*; returns its path.

    *builder*: ``"package.module:function"``, a function ``fn(sim) -> network`` that makes
    the network (and attaches the stations *nodes*) in the simulation it is given.
    *seed*: the default of the FMU's ``seed`` parameter; *size_bits*: the default message
    size (bits); *name*: the FMU's model identifier (a Python identifier).  The network is
    built once here, with ``Simulation(seed=seed)``, to check the builder and the station
    names before anything is written.
    """
    try:
        from pythonfmu.builder import FmuBuilder
    except ImportError:  # pragma: no cover - the tests have it
        raise ImportError("exporting an FMU needs pythonfmu: pip install pythonfmu") from None
    from ..sim import Simulation
    from .network_slave import load_builder
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ConfigurationError(f"FMU name must be a Python identifier, got {name!r}")
    if isinstance(nodes, str) or not nodes or not all(isinstance(n, str) and n for n in nodes):
        raise ConfigurationError(f"nodes must be a non-empty list of station names, got {nodes!r}")
    if len(set(nodes)) != len(nodes):
        raise ConfigurationError(f"nodes must be unique, got {list(nodes)!r}")
    seed = validate.integer(seed, "FMU seed", lo=0, hi=2 ** 31 - 1)
    size_bits = validate.bits(size_bits, "FMU size_bits", allow_zero=False)
    try:
        fn = load_builder(builder)
    except (ValueError, ImportError) as exc:
        raise ConfigurationError(f"network builder {builder!r}: {exc}") from None
    net = fn(Simulation(seed=seed))
    interfaces = getattr(net, "interfaces", None)
    if not isinstance(interfaces, dict):
        raise ConfigurationError(f"network builder {builder!r} returned {net!r}, not a network")
    missing = [n for n in nodes if n not in interfaces]
    if missing:
        raise ConfigurationError(f"network builder {builder!r}: the network has no station {missing[0]!r} "
                                 f"(stations: {list(interfaces)})")
    path = Path(path)
    if path.suffix != ".fmu":
        raise ConfigurationError(f"the FMU path must end in .fmu, got {str(path)!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    spec = {"builder": builder, "nodes": list(nodes), "size_bits": size_bits, "seed": seed}
    module = inspect.getmodule(fn)
    project = []
    source = getattr(module, "__file__", None)
    if module is not None and "." not in module.__name__ and source:
        project.append(Path(source))       # a one-file builder travels with the FMU
    with tempfile.TemporaryDirectory(prefix="netcosim-export-") as tmp:
        script = Path(tmp) / f"{name}.py"
        script.write_text(
            '"""A netcosim network exported as an FMU (netcosim.fmi.export)."""\n\n'
            "from netcosim.fmi.network_slave import NetworkSlave\n\n\n"
            f"class {name}(NetworkSlave):\n"
            f"    SPEC = {json.dumps(spec)}\n")
        sys.modules.pop(name, None)     # pythonfmu imports the script by its name: not an older one
        try:
            built = FmuBuilder.build_FMU(script, dest=path, project_files=project)
        finally:
            sys.modules.pop(name, None)
            if str(Path(tmp)) in sys.path:
                sys.path.remove(str(Path(tmp)))
    return Path(built)
