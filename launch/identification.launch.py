"""The whole identification graph, for machines with a full ROS 2 Jazzy install.

``ros2 launch scara_ident_ros identification.launch.py [bag:=PATH] [sim:=true]``
starts what ``scara-ident run`` starts: the simulated SCARA (unless ``sim:=false``,
e.g. with a real robot or ``scara-ident play``), one identifier serving three networks
side by side (FFMW, FFW, FFS publishing under /ffmw, /ffw, /ffs, fed by /joint_states) and
the MCAP recorder. The simulator waits (at most WAIT_TIMEOUT s) until the identifier and
the recorder have subscribed to /joint_states before its first sample (those two by name:
other subscribers on the domain do not count). The nodes run under ``SCHED_FIFO`` at the
priorities ``scara-ident run`` gives them (``GRAPH_PRIORITIES``), where the user may.

On Ctrl-C every node stops through its own stop (drain, save, statistics), which takes at
most ``STOP_TIMEOUT`` s (``scara_ident_ros.nodes.runtime``): launch's default grace (5 s
after SIGINT before SIGTERM, 10 s more before SIGKILL) is shorter, so each node is given
``STOP_GRACE`` s before launch escalates.

When the recorder exits, for whatever reason (``bag:=`` names a directory that exists
already, a full disk, a SIGINT of its own), the launch ends: the simulator and the
identifiers would otherwise go on with nothing recording them. When any node exits with a
non-zero code (it refused to start: a bad parameter, an existing bag; or it failed), the
launch ends too and ``ros2 launch`` exits 1: ``LaunchService.run`` returns 1 when an event
handler raises, and returns 0 after a ``Shutdown`` action whatever its reason, so the
handler raises (:func:`end_on_failure`).

``launch`` and ``launch_ros`` are imported when the description is generated, not when
the file is imported, so that the file can be read and checked without them.
"""
from scara_ident_ros.nodes.realtime import GRAPH_PRIORITIES
from scara_ident_ros.nodes.runtime import STOP_TIMEOUT
from scara_ident_ros.topics import JOINT_STATES, in_namespace

METHODS = ('ffmw', 'ffw', 'ffs')
WAIT_TIMEOUT = 60.0  # s, longest wait of the simulator for its subscribers (as scara-ident run)
STOP_GRACE = STOP_TIMEOUT + 5.0  # s after SIGINT before launch sends SIGTERM (and SIGKILL)


def end_on_failure(name, *, end_launch=False, log_info=None, shutdown=None):
    """An ``OnProcessExit`` callback for the node ``name``.

    A non-zero exit code (negative: a signal) raises ``RuntimeError``, which launch logs
    (``Caught exception in launch ...: <message>``) before it shuts every node down and
    returns 1. A clean exit ends the launch only if ``end_launch`` (through ``log_info`` and
    ``shutdown``, the launch classes, passed in so that this file imports without launch).
    """
    def on_exit(event, context):
        if event.returncode:
            raise RuntimeError(f'{name} exited with code {event.returncode}: ending the '
                               'launch')
        if end_launch:
            return [log_info(msg=f'{name} has exited: ending the launch'),
                    shutdown(reason=f'{name} exited')]
        return None
    return on_exit


def generate_launch_description():
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, LogInfo, RegisterEventHandler, Shutdown
    from launch.conditions import IfCondition
    from launch.event_handlers import OnProcessExit
    from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
    from launch_ros.actions import Node
    from launch_ros.substitutions import FindPackageShare

    config = PathJoinSubstitution([FindPackageShare('scara_ident_ros'), 'config'])
    grace = {'sigterm_timeout': str(STOP_GRACE), 'sigkill_timeout': str(STOP_GRACE)}
    recorder = Node(package='scara_ident_ros', executable='recorder', name='recorder',
                    parameters=[PathJoinSubstitution([config, 'recorder.yaml']),
                                {'output': LaunchConfiguration('bag'),
                                 'realtime_priority': GRAPH_PRIORITIES['recorder']}], **grace)
    simulator = Node(package='scara_ident_ros', executable='scara_sim', name='scara_sim',
                     parameters=[PathJoinSubstitution([config, 'scara_sim.yaml']),
                                 {'wait_for_subscribers': 2,
                                  'wait_for_nodes': ['/recorder', '/identifier'],
                                  'wait_timeout': WAIT_TIMEOUT,
                                  'realtime_priority': GRAPH_PRIORITIES['simulator']}],
                     condition=IfCondition(LaunchConfiguration('sim')), **grace)
    identifier = Node(
        package='scara_ident_ros', executable='identifier', name='identifier',
        parameters=[PathJoinSubstitution([config, 'identifier.yaml']),
                    {'methods': list(METHODS), 'wait_for_subscribers': 1,
                     'wait_for_nodes': ['/recorder'], 'wait_timeout': WAIT_TIMEOUT,
                     'realtime_priority': GRAPH_PRIORITIES['identifier']}],
        remappings=[(JOINT_STATES, in_namespace(JOINT_STATES))], **grace)
    actions = [
        DeclareLaunchArgument('bag', default_value='scara_ident_run',
                              description='Directory of the MCAP bag to record'),
        DeclareLaunchArgument('sim', default_value='true',
                              description='Start the simulated SCARA'),
        # Like scara-ident run: the simulator starts publishing only once the identifier
        # and the recorder below are subscribed to /joint_states, and the identifier
        # subscribes only once the recorder records its outputs, so that nothing misses
        # the first samples or predictions.
        # The handlers first, so that they hear a node that exits at once.
        # Nothing is worth running once nothing records: end the launch with the recorder.
        RegisterEventHandler(OnProcessExit(
            target_action=recorder,
            on_exit=end_on_failure('the recorder', end_launch=True, log_info=LogInfo,
                                   shutdown=Shutdown))),
        # A node that fails (or refuses to start) ends the launch, with exit code 1.
        RegisterEventHandler(OnProcessExit(target_action=simulator,
                                           on_exit=end_on_failure('scara_sim'))),
        RegisterEventHandler(OnProcessExit(target_action=identifier,
                                           on_exit=end_on_failure('the identifier'))),
        simulator,
        recorder,
        identifier,
    ]
    return LaunchDescription(actions)
