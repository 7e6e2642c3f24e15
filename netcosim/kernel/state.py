"""What a node's kernel holds, shared by its parts.

A :class:`~netcosim.kernel.node.Node` is one object built from four parts, each in its
module: :class:`~netcosim.kernel.overrun.Overruns` (deadline and budget timers),
:class:`~netcosim.kernel.interpreter.Interpreter` (running a job's body),
:class:`~netcosim.kernel.dispatcher.Dispatcher` (ready queue, choice of the job to run,
preemption, context switches, priority inheritance) and the node itself (the public
face).  They are base classes of the node, not objects it delegates to, so a call from
one part to another is a plain method call on the node: the split costs no Python call
per job.  :class:`KernelState` declares (annotations only: no code, no attributes at
run time) the state ``Node.__init__`` sets and the methods one part calls in a later one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:
    from ..clock import Rearmable, Timer
    from ..recorder import Sink
    from .policies import SchedulingPolicy
    from .ready import ReadyQueue
    from .releases import Releases
    from .task import Job, Task


class KernelState:
    """The attributes of a node's kernel, by owner (see the module docstring)."""

    # the node
    sim: Any
    name: str
    policy: SchedulingPolicy
    tasks: dict[str, Task]
    _env: Any                   # the Engine: `now` is always integer ticks
    _sched: Sink                # schedule rows (kernel.tables.SCHEDULE_RAW)
    _jobrec: Sink               # job rows (kernel.tables.JOB_RAW)
    _releases: Releases
    # the dispatcher
    ready: ReadyQueue
    _seq: int                   # activations so far (FIFO order among equal keys)
    _dispatch_pending: bool
    _dispatch_event: Rearmable
    _dispatch_callbacks: list[Callable]
    _choose: Callable[[ReadyQueue, Any], Job | None] | None  # the policy's `choose`, if it has its own
    # the CPU: the node's own on a one-core node; a multicore node's cores hold these per
    # core (kernel.multicore.Core, itself a Dispatcher), the node's stay unused
    running: Job | None
    _loaded: Job | None         # the job whose context is on the CPU
    _in_cs: bool                # a context switch is under way
    _np_job: Job | None         # non-preemptible job interrupted by a handler
    _cs_ticks: int
    _pw: Any                    # speed and energy (kernel.power.NodePower): the switch under way, the meter
    _cs_done: Callable[[Any], None]
    _spare_timer: Timer | None  # a fired segment timer, re-armed for the next segment
    _segment_cb: Callable[[Any], None]
    _segment_cbs: list[Callable[[Any], None]]
    # methods a part calls in a part defined after it
    _trace: Callable[[Task, str], None]
    _activate: Callable[[Job], None]
    _request_dispatch: Callable[[], None]
    _dispatch: Callable[..., None]
    _kill: Callable[[Job], None]
