"""Real-time scheduling of a node's threads: the stream's processes run when their sample is due.

On a machine whose CPUs are shared (the learners beside the identifier, a test run, a
build), the kernel's fair scheduler let the simulator's thread wait on the run queue for
up to 0.3-0.5 s while it was due to publish (``/proc/thread-self/schedstat``: 13 s of 29 s
runnable but not running), and every node after it waited with it: the graph's stalls
(``benchmarks/subscriber_lag.md``). Under ``SCHED_FIFO`` a thread runs as soon as it is
runnable, before every thread of the fair scheduler, as ``ros2_control``'s
``controller_manager`` runs its loop (``thread_priority``).

:func:`use_realtime_priority` puts every thread the process has (the node's, the
executor's and DDS's) under ``SCHED_FIFO`` with ``SCHED_RESET_ON_FORK``: a thread or process
started later (a learner process) runs at normal priority. It needs ``CAP_SYS_NICE`` or an
``RLIMIT_RTPRIO`` of at least the priority (``ulimit -r``; ``@realtime - rtprio 99`` in
``/etc/security/limits.conf``, as ros2_control's docs ask); refused, the node says why in
one warning and runs at normal priority. The kernel's real-time throttling
(``/proc/sys/kernel/sched_rt_runtime_us``, 95 % of each CPU by default) bounds what a
real-time thread can take from the others.
"""
from __future__ import annotations

import os
import resource

from scara_ident_ros.parameter_spec import ParamSpec

__all__ = ['GRAPH_PRIORITIES', 'REALTIME_PRIORITY', 'use_realtime_priority']

#: The parameter of every node of the stream (simulator, identifier, recorder).
REALTIME_PRIORITY = ParamSpec(
    'realtime_priority', 0, "SCHED_FIFO priority (1-99) of the node's threads once it is "
    'built, so that its samples wait for no other process (needs CAP_SYS_NICE or ulimit -r '
    'of at least this; refused: a warning and normal scheduling); processes it starts '
    'afterwards run at normal priority; 0: normal scheduling', min=0, max=99,
    fixed='set once, when the node is built')

#: The priorities ``scara-ident run`` and the launch file give the graph's nodes, by role:
#: the simulator's stream first, then the predictions, then the recorder; the learners and
#: everything else after them.
GRAPH_PRIORITIES = {'simulator': 30, 'identifier': 20, 'recorder': 10}

TASKS = '/proc/self/task'  # one entry per thread of this process, by thread id


def use_realtime_priority(priority: int) -> str:
    """Put every thread of this process under ``SCHED_FIFO`` at ``priority`` (reset on fork).

    Parameters
    ----------
    priority : int
        1 (lowest) to 99.

    Returns
    -------
    str
        ``''`` once every thread runs at that priority, else why not (one line); the
        threads then keep their normal scheduling.
    """
    if not 1 <= priority <= 99:
        raise ValueError(f'realtime_priority must be 1-99, got {priority}')
    policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
    done: list[int] = []
    for name in os.listdir(TASKS):
        tid = int(name)
        try:
            os.sched_setscheduler(tid, policy, os.sched_param(priority))
        except ProcessLookupError:  # a thread that has ended meanwhile
            continue
        except PermissionError:
            for earlier in done:  # all or none: a half real-time process waits on itself
                os.sched_setscheduler(earlier, os.SCHED_OTHER, os.sched_param(0))
            limit = resource.getrlimit(resource.RLIMIT_RTPRIO)[0]
            return (f'SCHED_FIFO priority {priority} refused (it needs CAP_SYS_NICE or '
                    f'ulimit -r >= {priority}; ulimit -r is {limit}): normal scheduling')
        done.append(tid)
    return ''
