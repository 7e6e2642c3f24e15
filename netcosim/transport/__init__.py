"""Hardware-in-the-loop: real processes in place of simulated nodes, over Eclipse Zenoh.

Modules (import them directly; this package imports none of them, so that the real
process can load :mod:`netcosim.transport.client` without SimPy, NumPy or CasADi):

:mod:`netcosim.transport.wire`
    the versioned wire format (``struct``, float64 payloads; never pickle); the same
    for C programs: ``ncsm_wire.h`` beside it
:mod:`netcosim.transport.cdr`
    the same message as CDR on rmw_zenoh key expressions (ROS 2-friendly)
:mod:`netcosim.transport.codecs`
    one interface to both encodings
:mod:`netcosim.transport.realtime`
    :class:`~netcosim.transport.realtime.RealtimeClock`: wall-clock pacing with an inbox
    other threads can post to, and the lateness histogram
:mod:`netcosim.transport.session`
    hermetic Zenoh sessions (peer mode, no scouting, loopback endpoints, per-run keys)
:mod:`netcosim.transport.base`
    :class:`~netcosim.transport.base.BaseRemote`: what every remote shares -- the session,
    the claim, requests and deadlines, the matching of replies, drops by reason, counters,
    the loss policy and the ``hil`` trace rows
:mod:`netcosim.transport.remote`
    :class:`~netcosim.transport.remote.RemoteNode`: a simulated node whose tasks run in
    another process; :class:`~netcosim.transport.remote.RemotePlantIO`: a process reading
    a simulated plant's outputs and writing its inputs
:mod:`netcosim.transport.harness`
    the remote program's command line and one run with it, from connection to the last
    reply, for one or several remotes (:func:`~netcosim.transport.harness.run_with_remotes`)
:mod:`netcosim.transport.client`
    the library the real process uses (stdlib and Zenoh only)

Zenoh (the ``zenoh`` extra, ``eclipse-zenoh``) is imported only when a session is opened.
"""

__all__: list[str] = []
