"""The whole identification graph, for machines with a full ROS 2 Jazzy install.

``ros2 launch scara_ident_ros identification.launch.py [bag:=PATH] [sim:=true]``
starts what ``scara-ident run`` starts: the simulated SCARA (unless ``sim:=false``,
e.g. with a real robot or ``scara-ident play``), one identifier serving three networks
side by side (FFMW, FFW, FFS publishing under /ffmw, /ffw, /ffs, fed by /joint_states) and
the MCAP recorder. The simulator waits (at most WAIT_TIMEOUT s) until the identifier and
the recorder have subscribed to /joint_states before its first sample.

On Ctrl-C every node stops through its own stop (drain, save, statistics), which takes at
most ``STOP_TIMEOUT`` s (``scara_ident_ros.nodes.runtime``): launch's default grace (5 s
after SIGINT before SIGTERM, 10 s more before SIGKILL) is shorter, so each node is given
``STOP_GRACE`` s before launch escalates.

When the recorder exits, for whatever reason (``bag:=`` names a directory that exists
already, a full disk, a SIGINT of its own), the launch ends: the simulator and the
identifiers would otherwise go on with nothing recording them.

``launch`` and ``launch_ros`` are imported when the description is generated, not when
the file is imported, so that the file can be read and checked without them.
"""
from scara_ident_ros.nodes.runtime import STOP_TIMEOUT
from scara_ident_ros.topics import JOINT_STATES, in_namespace

METHODS = ('ffmw', 'ffw', 'ffs')
WAIT_TIMEOUT = 60.0  # s, longest wait of the simulator for its subscribers (as scara-ident run)
STOP_GRACE = STOP_TIMEOUT + 5.0  # s after SIGINT before launch sends SIGTERM (and SIGKILL)


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
                                {'output': LaunchConfiguration('bag')}], **grace)
    actions = [
        DeclareLaunchArgument('bag', default_value='scara_ident_run',
                              description='Directory of the MCAP bag to record'),
        DeclareLaunchArgument('sim', default_value='true',
                              description='Start the simulated SCARA'),
        # Like scara-ident run: the simulator starts publishing only once the identifier
        # and the recorder below are subscribed to /joint_states, and the identifier
        # subscribes only once the recorder records its outputs, so that nothing misses
        # the first samples or predictions.
        Node(package='scara_ident_ros', executable='scara_sim', name='scara_sim',
             parameters=[PathJoinSubstitution([config, 'scara_sim.yaml']),
                         {'wait_for_subscribers': 2, 'wait_timeout': WAIT_TIMEOUT}],
             condition=IfCondition(LaunchConfiguration('sim')), **grace),
        recorder,
        # Nothing is worth running once nothing records: end the launch with the recorder.
        RegisterEventHandler(OnProcessExit(
            target_action=recorder,
            on_exit=[LogInfo(msg='the recorder has exited: ending the launch'),
                     Shutdown(reason='the recorder exited')])),
    ]
    actions.append(Node(
        package='scara_ident_ros', executable='identifier', name='identifier',
        parameters=[PathJoinSubstitution([config, 'identifier.yaml']),
                    {'methods': list(METHODS), 'wait_for_subscribers': 1,
                     'wait_timeout': WAIT_TIMEOUT}],
        remappings=[(JOINT_STATES, in_namespace(JOINT_STATES))], **grace))
    return LaunchDescription(actions)
