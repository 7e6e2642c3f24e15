"""``netcosim hil SCENARIO --remote NAME``: one node or plant of a scenario in another process (Zenoh)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ._common import UsageError, check_writable_dir
from .run import resolve_experiment


def _names(csv: str | None) -> list[str] | None:
    """``"a,b"`` -> ``["a", "b"]`` (None stays None: all)."""
    return None if csv is None else [n.strip() for n in csv.split(",") if n.strip()]


def _plant_deviation(hil_sim, ref_sim) -> list[tuple[str, str, float]]:
    """``(plant, signal, max |hil - reference|)`` for every plant output (``y.*``; every
    plant signal if none) both runs logged (the reference interpolated linearly on the
    HIL run's times)."""
    import numpy as np
    a, b = hil_sim.trace.signals(), ref_sim.trace.signals()
    out = []
    a = a[a["source"].isin(list(hil_sim.plants))]
    if a["signal"].astype(str).str.startswith("y.").any():     # the outputs, when the plants log them
        a = a[a["signal"].astype(str).str.startswith("y.")]
    for (src, sig), ga in a.groupby(["source", "signal"], observed=True):
        gb = b[(b["source"] == src) & (b["signal"] == sig)]
        if len(ga) and len(gb):
            diff = ga["value"].to_numpy() - np.interp(ga["time"], gb["time"], gb["value"])
            out.append((str(src), str(sig), float(np.max(np.abs(diff)))))
    return out


def _hil_report(run, args, compare_with) -> None:
    import numpy as np
    remote = run.remote
    c = remote.counters()
    lat = run.lateness
    resp = remote.response_times()
    print(f"requests to the remote: {c['published']} published ({c['overruns']} overruns, {c['unserved']} unserved), "
          f"replies applied: {c['received']} (+{c['after_end']} after the end), expired: {c['expired']}, "
          f"dropped: {c['dropped']}, refused claimants: {c['refused']}")
    if len(resp):
        q = np.quantile(resp, [0.5, 0.9, 0.99]) * 1e3
        print(f"response time (simulated): median {q[0]:.3f} ms, p90 {q[1]:.3f} ms, p99 {q[2]:.3f} ms, "
              f"max {resp.max() * 1e3:.3f} ms over {len(resp)} replies")
    print(f"lateness: median <= {lat.quantile(0.5) * 1e3:.3f} ms, p99 <= {lat.quantile(0.99) * 1e3:.3f} ms, "
          f"max {lat.max * 1e3:.3f} ms, overruns {lat.overruns} of {lat.events} events")
    if run.process is not None:
        print(f"remote process: {run.process}")
    print(remote.events().to_string(index=False))
    if run.failure is not None:
        print(f"the run failed at t = {run.sim.now:.6f} s: {type(run.failure).__name__}: {run.failure}")
    for label, ref in compare_with:
        rows = _plant_deviation(run.sim, ref)
        worst = max(rows, key=lambda r: r[2]) if rows else None
        print(f"max deviation from the {label}: " + (f"{worst[2]:.3e} ({worst[0]}.{worst[1]})" if worst else
                                                       "no plant signal logged in both runs"))


def _checked(check, value, flag: str, **kw):
    """``check(value, flag, **kw)`` (a :mod:`netcosim.validate` function), its error a :class:`UsageError`."""
    from ..errors import ConfigurationError, ConfigurationTypeError
    try:
        return check(value, flag, **kw)
    except (ConfigurationError, ConfigurationTypeError) as exc:
        raise UsageError(str(exc)) from None


#: Zenoh link protocols whose address is HOST:PORT.
_HOST_PORT_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")


def check_endpoint(endpoint: str, flag: str) -> str:
    """*endpoint* if it reads as a Zenoh endpoint ``<protocol>/<address>[?<metadata>][#<config>]``
    (HOST:PORT for tcp, udp, tls, quic, ws; port 0, "any", only for ``--listen``); raises
    :class:`UsageError` naming *flag* and *endpoint* otherwise."""
    import re
    m = re.fullmatch(r"([a-z][a-z0-9-]*)/([^?#]+)(\?[^#]*)?(#.*)?", endpoint)
    if m is None:
        raise UsageError(f"{flag} {endpoint!r} is not a Zenoh endpoint <protocol>/<address> "
                         "(e.g. tcp/127.0.0.1:7447)")
    if m.group(1) in _HOST_PORT_PROTOCOLS:
        host, colon, port = m.group(2).rpartition(":")
        lowest = 0 if flag == "--listen" else 1
        if not (colon and host and port.isdigit() and lowest <= int(port) <= 65535):
            raise UsageError(f"{flag} {endpoint!r}: a {m.group(1)} address is HOST:PORT with a port in "
                             f"{lowest}..65535")
    return endpoint


def _check_signature(fn, spec: str, flag: str, expected: str, *sample) -> None:
    """Refuse *fn* (named *spec*, given as *flag*) if it cannot be called with *sample*
    arguments, naming the *expected* signature, before it is called."""
    import inspect
    if inspect.isclass(fn):
        raise UsageError(f"{flag} {spec!r} is a class; it must be a function {expected}")
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):         # a builtin without a signature: let the call say it
        return
    try:
        sig.bind(*sample)
    except TypeError:
        raise UsageError(f"{flag} {spec!r} has the signature {sig}; it must be a function {expected}") from None


def _check_hil_options(args) -> None:
    """Every ``hil`` option that does not need the scenario, before anything is built or opened."""
    import shlex

    from .. import validate
    from ..transport.wire import MAX_VALUES
    _checked(validate.duration, args.until, "--until", positive=True, kind="a positive number of seconds")
    _checked(validate.positive, args.factor, "--factor",
             kind="a positive finite number (wall-clock seconds per simulated second)")
    for flag, value in (("--period", args.period), ("--deadline", args.deadline)):
        if value is not None:
            _checked(validate.duration, value, flag, positive=True, kind="a positive number of seconds")
    if args.max_outstanding is not None:
        _checked(validate.count, args.max_outstanding, "--max-outstanding", minimum=1)
    if args.reply_values is not None:
        _checked(validate.count, args.reply_values, "--reply-values", minimum=0, maximum=MAX_VALUES)
    _checked(validate.bits, args.size_bits, "--size-bits", allow_zero=False)
    _checked(validate.real, args.lease, "--lease", lo=0.01, hi=3600.0, kind="a number of seconds in [0.01, 3600]")
    _checked(validate.non_negative, args.wait, "--wait", kind="a non-negative finite number of seconds")
    for flag, endpoints in (("--listen", args.listen), ("--connect", args.connect)):
        for e in endpoints:
            check_endpoint(e, flag)
    if args.zenoh_config is not None and not Path(args.zenoh_config).is_file():
        raise UsageError(f"--zenoh-config {args.zenoh_config!r}: no such file")
    try:
        words = shlex.split(args.remote_cmd)
    except ValueError as exc:
        raise UsageError(f"--remote-cmd {args.remote_cmd!r}: {exc}") from None
    if not words:
        raise UsageError(f"--remote-cmd must name a program, got {args.remote_cmd!r}")
    for flag, names in (("--outputs", args.outputs), ("--inputs", args.inputs), ("--abort-on", args.abort_on)):
        if names is not None and not _names(names):
            raise UsageError(f"{flag} {names!r} names nothing (give NAME[,NAME...])")
    check_writable_dir(args.out, "--out")


def _zenoh_reason(exc: BaseException) -> str:
    """The first line of a Zenoh error without the Rust source location it ends with."""
    import re
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return re.sub(r"\s+at \S+\.rs:\d+\.?$", "", text)


def _check_plant_ports(plant, args) -> None:
    """``--outputs`` / ``--inputs`` name ports of *plant*."""
    from ..errors import ConfigurationTypeError
    for flag, given, select in (("--outputs", args.outputs, plant.output), ("--inputs", args.inputs, plant.input)):
        if given is not None:
            try:
                select(_names(given))
            except (KeyError, IndexError, ConfigurationTypeError) as exc:
                raise UsageError(f"{flag} {given!r}: {exc.args[0] if exc.args else exc}") from None


def _hil(args) -> int:
    import shlex
    from pathlib import Path

    from ..errors import NetcosimError
    from ..transport.harness import remote_command, run_with_remote
    from ..transport.remote import DROP_REASONS, LOSS_EVENTS, RemoteNode, RemotePlantIO
    from ..transport.session import LOOPBACK, new_run_id, open_session

    if ":" not in args.scenario:
        raise UsageError(f"scenario {args.scenario!r}: give package.module:function or path/to/file.py:function")
    _check_hil_options(args)
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    build = resolve_experiment(args.scenario)
    _check_signature(build, args.scenario, "scenario", "build() -> Simulation (called with no argument)")
    if args.replay is not None:
        replay = resolve_experiment(args.replay)
        _check_signature(replay, args.replay, "--replay", "FUNCTION(until, requests) -> Simulation", 1.0, [])
    if args.extra is not None:
        _check_signature(resolve_experiment(args.extra), args.extra, "--extra", "FUNCTION(built)", None)
    built = build()
    sim = built[0] if isinstance(built, tuple) else built
    is_node = args.remote in getattr(sim, "nodes", {})
    if not is_node and args.remote not in getattr(sim, "plants", {}):
        raise UsageError(f"scenario {args.scenario!r} has no node or plant {args.remote!r}")
    plant_options = [o for o, v in (("--outputs", args.outputs), ("--inputs", args.inputs), ("--extra", args.extra))
                     if v is not None]
    if is_node and plant_options:
        raise UsageError(f"{args.remote!r} is a node, not a plant: {', '.join(plant_options)} given")
    if not is_node and args.period is None:
        raise UsageError(f"{args.remote!r} is a plant: give its sampling period with --period SECONDS")
    if not is_node:
        _check_plant_ports(sim.plants[args.remote], args)
    if is_node and args.period is None and args.deadline is None:
        raise UsageError(f"{args.remote!r} is a node: give the period of the requests it serves with "
                         "--period SECONDS (the default deadline), or --deadline SECONDS")
    abort_on = _names(args.abort_on) or []
    bad = sorted(set(abort_on) - set(DROP_REASONS) - set(LOSS_EVENTS))
    if bad:
        raise UsageError(f"--abort-on {', '.join(bad)}: not one of {', '.join(DROP_REASONS + LOSS_EVENTS)}")
    if args.replay is not None and not args.compare:
        raise UsageError("--replay needs --compare")
    replay = None if args.replay is None else resolve_experiment(args.replay)      # checked above
    extra = None if args.extra is None else resolve_experiment(args.extra)(built)
    listen = args.listen or ([] if args.connect else [LOOPBACK])
    run = new_run_id()
    kw = {} if args.zenoh_config is None else {"config": args.zenoh_config}
    try:
        session = open_session(listen=listen, connect=args.connect, lease=args.lease, **kw)
    except (OSError, ValueError, RuntimeError) as e:
        raise UsageError(str(e)) from None
    except Exception as e:      # zenoh.ZError (not importable without the zenoh extra): an endpoint Zenoh refuses
        if type(e).__name__ != "ZError":
            raise
        where = " ".join(f"--listen {x}" for x in args.listen) + " ".join(f" --connect {x}" for x in args.connect)
        raise UsageError(f"cannot open a Zenoh session ({where.strip() or 'default endpoints'}): "
                         f"{_zenoh_reason(e)}") from None
    try:
        common = dict(deadline=args.deadline, max_outstanding=args.max_outstanding, loss_policy=args.loss_policy,
                      abort_on=abort_on, encoding=args.encoding, factor=args.factor)
        remote: RemoteNode | RemotePlantIO
        try:
            if is_node:
                remote = RemoteNode(sim, args.remote, session, run=run, size_bits=args.size_bits, period=args.period,
                                    reply_values=args.reply_values, **common)
            else:
                remote = RemotePlantIO(sim, sim.plants[args.remote], session, run=run, period=args.period,
                                       outputs=_names(args.outputs), inputs=_names(args.inputs), extra=extra,
                                       **common)
        except NetcosimError as e:
            raise UsageError(str(e)) from None
        cmd = remote_command(shlex.split(args.remote_cmd), run=run, node=args.remote,
                             endpoints=args.connect or session.endpoints, lease=args.lease,
                             session=remote.session_id, zenoh_config=args.zenoh_config, encoding=args.encoding)
        try:
            result = run_with_remote(sim, remote, args.until, cmd, spawn=False, connect_timeout=args.wait)
        except TimeoutError as e:
            print(f"netcosim hil: {e}", file=sys.stderr)
            return 1
    finally:
        session.close()
    compare_with = []
    if args.compare:
        ref_built = build()
        ref = ref_built[0] if isinstance(ref_built, tuple) else ref_built
        ref.run(until=args.until)
        compare_with.append(("all-simulated run", ref))
        if replay is not None:
            compare_with.append(("replay with the measured response times", replay(args.until, remote.requests())))
    _hil_report(result, args, compare_with)
    out = Path(args.out) / run
    result.save(out)
    print(f"trace and counters written to {out}")
    return 1 if result.failure is not None else 0


def add_parser(sub) -> None:
    """Add the ``hil`` subcommand to the subparsers *sub* of the ``netcosim`` parser."""
    h = sub.add_parser("hil", help="run a scenario in real time with one node in another process (Zenoh)",
                       description="Build SCENARIO, make NODE remote, print the command that starts the remote "
                                   "side, wait for it, run in real time (see docs/hil.md).")
    h.add_argument("scenario", help="package.module:function or path/to/file.py:function returning a Simulation "
                                    "(or a tuple starting with one)")
    h.add_argument("--remote", required=True, metavar="NAME",
                   help="the node whose tasks run in the remote process, or a plant the process reads and drives "
                        "(remote plant I/O: give --period)")
    h.add_argument("--until", type=float, default=5.0, help="simulated seconds to run (default 5)")
    h.add_argument("--factor", type=float, default=1.0,
                   help="wall-clock seconds per simulated second (default 1: real time)")
    h.add_argument("--period", type=float, metavar="SECONDS",
                   help="node: the period of the requests it serves (the default deadline); plant: the sampling "
                        "period (s) of the outputs sent to the process")
    h.add_argument("--deadline", type=float, metavar="SECONDS",
                   help="a reply must arrive within this many simulated seconds of its request (default: --period)")
    h.add_argument("--reply-values", type=int, metavar="N",
                   help="node: number of values every reply must carry (default: any)")
    h.add_argument("--max-outstanding", type=int, metavar="N",
                   help="requests that may wait for a reply at once (default: ceil(deadline / period) + 1)")
    h.add_argument("--abort-on", metavar="REASON,...",
                   help="end the run (trace kept, END sent, exit status 1) on these drop reasons or on expired, "
                        "overrun, lost (default: never; they are dropped and counted)")
    h.add_argument("--outputs", metavar="A,B", help="remote plant: the outputs sent, by name (default all)")
    h.add_argument("--inputs", metavar="A,B", help="remote plant: the inputs the process writes (default all)")
    h.add_argument("--extra", metavar="MODULE:FUNCTION",
                   help="remote plant: FUNCTION(what SCENARIO returned) gives extra(t), whose values follow the "
                        "outputs in every sample (e.g. a reference)")
    h.add_argument("--connect", action="append", default=[], metavar="tcp/HOST:PORT",
                   help="a Zenoh router (or peer) to connect to; then nothing listens unless --listen is given")
    h.add_argument("--listen", action="append", default=[], metavar="tcp/HOST:PORT",
                   help="endpoint to listen on (default tcp/127.0.0.1:0 without --connect)")
    h.add_argument("--zenoh-config", metavar="PATH",
                   help="a Zenoh configuration file for both sides (authentication, TLS; docs/hil_security.md)")
    h.add_argument("--encoding", choices=["ncsm", "cdr"], default="ncsm",
                   help="message encoding: ncsm (native, default) or cdr (CDR on rmw_zenoh keys, for ROS 2 tools)")
    h.add_argument("--size-bits", type=int, default=80, help="size (bits) of each message the remote sends")
    h.add_argument("--loss-policy", choices=["hold", "zero"], default="hold",
                   help="at a lost reply (expired, overrun, remote lost): keep the last command (hold) or send "
                        "zeros (zero)")
    h.add_argument("--lease", type=float, default=1.0, help="liveliness lease (s): a silent remote is lost after it")
    h.add_argument("--wait", type=float, default=60.0, help="seconds to wait for the remote side to connect")
    h.add_argument("--remote-cmd", default="python -m netcosim.transport.client",
                   help="the remote program, printed with --run/--node/--session/--connect (default: the echo "
                        "process; a leading 'python' is the running interpreter)")
    h.add_argument("--out", default="results/hil", metavar="DIR",
                   help="write the trace, the hil tables and the counters to DIR/<run id> (default results/hil)")
    h.add_argument("--compare", action="store_true",
                   help="then run SCENARIO all-simulated and print the largest deviation of the plant signals")
    h.add_argument("--replay", metavar="MODULE:FUNCTION",
                   help="with --compare: FUNCTION(until, requests) runs the all-simulated scenario replaying the "
                        "measured response times (e.g. netcosim.experiments.hil_servo:run_replay)")
    h.set_defaults(fn=_hil)
