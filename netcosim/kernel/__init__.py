"""Real-time kernel: nodes, tasks, scheduling policies, synchronisation, analog I/O."""

from .io import AnalogIn, AnalogOut
from .localclock import LocalClock
from .node import Node
from .policies import EDF, DeadlineMonotonic, FixedPriority, RateMonotonic, SchedulingPolicy
from .sync import ConditionVariable, Mailbox, Monitor, Semaphore
from .task import Job, Task, TaskContext
from .timers import KernelTimer, Trigger

__all__ = ["AnalogIn", "AnalogOut", "ConditionVariable", "DeadlineMonotonic", "EDF", "FixedPriority", "Job",
           "KernelTimer", "LocalClock", "Mailbox", "Monitor", "Node", "RateMonotonic", "SchedulingPolicy", "Semaphore",
           "Task", "TaskContext", "Trigger"]
