"""Real-time kernel: nodes, tasks, scheduling policies, synchronisation, analog I/O."""

from .io import AnalogIn, AnalogOut
from .node import KernelTimer, Node, Trigger
from .policies import EDF, DeadlineMonotonic, FixedPriority, RateMonotonic, SchedulingPolicy
from .sync import Event, Mailbox, Monitor, Semaphore
from .task import Job, Task, TaskContext

__all__ = ["AnalogIn", "AnalogOut", "DeadlineMonotonic", "EDF", "Event", "FixedPriority", "Job",
           "KernelTimer", "Mailbox", "Monitor", "Node", "RateMonotonic", "SchedulingPolicy", "Semaphore",
           "Task", "TaskContext", "Trigger"]
