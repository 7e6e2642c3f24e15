"""``netcosim export-fmu BUILDER --nodes A,B --out NET.fmu``: a network as an FMI 2.0 co-simulation FMU.

BUILDER is ``package.module:function``, a function ``fn(sim) -> network`` that makes the
network (and may add kernel nodes) in the simulation it is given; ``--nodes`` the stations
that get FMU ports (see :mod:`netcosim.fmi.network_slave` for the port mapping and
docs/fmi.md).  Modules are also looked up in the current directory.
"""

from __future__ import annotations

import os
import sys

from ._common import UsageError


def add_parser(sub) -> None:
    """Add the ``export-fmu`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    ex = sub.add_parser("export-fmu", help="package a network (optionally with kernels) as an FMI 2.0 "
                                           "co-simulation FMU",
                        description="Write an FMI 2.0 co-simulation FMU (built with pythonfmu) whose inputs are "
                                    "messages to send and whose outputs are the delivered messages with their "
                                    "delays (docs/fmi.md, 'Export').")
    ex.add_argument("builder", help="package.module:function, called as fn(sim) and returning the network")
    ex.add_argument("--nodes", required=True, metavar="A,B,...", help="the stations that get FMU ports")
    ex.add_argument("--out", required=True, metavar="NET.fmu", help="the FMU file to write")
    ex.add_argument("--seed", type=int, default=0, help="default of the FMU's seed parameter (default 0)")
    ex.add_argument("--size-bits", type=int, default=256, help="default message size in bits (default 256)")
    ex.add_argument("--name", default="NetcosimNetwork", help="the FMU's model identifier (a Python identifier)")
    ex.set_defaults(fn=_export)


def _export(args) -> int:
    from ..errors import ConfigurationError
    from ..fmi.export import export_network_fmu
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    nodes = [n.strip() for n in args.nodes.split(",") if n.strip()]
    try:
        path = export_network_fmu(args.builder, nodes, args.out, seed=args.seed, size_bits=args.size_bits,
                                  name=args.name)
    except ConfigurationError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {path}")
    return 0
