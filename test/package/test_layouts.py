"""The shipped plot layouts name only what the nodes publish, and mean what they say.

``config/foxglove_layout.json`` names series by Foxglove message path
(``/ffmw/identified_torque.effort[0]``); ``config/plotjuggler_layout.xml`` by PlotJuggler
series name: ``/topic/field[index]`` in general, ``/topic/<joint name>/<field>`` for a
``sensor_msgs/JointState`` (PlotJuggler's ROS parser names those by joint).

What the graph publishes is not copied here: the simulator and the three identifiers are
built in-process as ``scara-ident run`` starts them (namespaces ``/<method>`` for every
method of :data:`scara_ident_ros.nn.presets.METHODS`, ``joint_states`` remapped to
``/joint_states``). Their publishers give the topic names and message classes; the
messages they publish on a few hundred simulated samples give the joint names, the array
lengths and the labels of ``identification_mse``'s dimensions. Nothing is sent: each
publisher's ``publish`` is replaced by a recorder before the first message.

Every series must resolve, field by field (``get_fields_and_field_types`` of the rosidl
class), index by index, to a number in such a message; its panel title or label must name
what the index means (the joint, the metric of ``identification_mse``, the method); and
together the series must cover every joint's effort and every element of every
``identification_mse``. The tests on deliberately broken copies show that the checks fail.
"""
from __future__ import annotations

import copy
import json
import re
import runpy
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import rclpy
from rclpy.serialization import deserialize_message
from rclpy.node import Node

from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.nodes.identifier import IdentifierNode
from scara_ident_ros.nodes.scara_sim import ScaraSimNode

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
FOXGLOVE = REPO / 'config' / 'foxglove_layout.json'
PLOTJUGGLER = REPO / 'config' / 'plotjuggler_layout.xml'
SAMPLES = 300  # simulated samples (0.3 s at 1 kHz): every output is published at least once
FOXGLOVE_STAMPS = ('receiveTime', 'headerStamp')  # Foxglove's timestampMethod values
JOINT_STATE_FIELDS = ('position', 'velocity', 'effort')  # PlotJuggler: /topic/<joint>/<field>
FIELD = re.compile(r'(?P<name>[A-Za-z_][A-Za-z0-9_]*)(?:\[(?P<index>\d+)\])?')
FOXGLOVE_PATH = re.compile(r'(?P<topic>/[A-Za-z0-9_/]+)\.(?P<fields>.+)')

Step = tuple[str, int | None]  # a field name and, for an array, the index into it


class LayoutError(Exception):
    """A layout entry that does not resolve to a published number; the message says why."""


@dataclass(frozen=True)
class Graph:
    """What the nodes publish, per resolved topic name.

    Attributes
    ----------
    types : dict of str to type
        The message class of each topic a node publishes.
    messages : dict of str to message
        The last message published on it, for the topics that had one (not those of
        timers that did not fire, such as ``/diagnostics``).
    """

    types: dict[str, Any]
    messages: dict[str, Any]


@contextmanager
def recorded(make_node: Callable[[], Node], ros_args: list[str],
             graph: dict[str, list[Any]], types: dict[str, Any]) -> Iterator[Node]:
    """Build a node in the default context initialised with ``ros_args``.

    Each of its publishers appends a copy of what it would publish to ``graph[topic]``
    instead of sending it; ``types[topic]`` is the publisher's message class.
    """
    rclpy.init(args=['--ros-args', *ros_args])
    try:
        node = make_node()
        try:
            with pytest.MonkeyPatch.context() as patch:
                for publisher in node.publishers:
                    topic = publisher.topic_name
                    types[topic] = publisher.msg_type
                    sent = graph.setdefault(topic, [])
                    # a node may publish a message object or its serialized bytes
                    def capture(msg: Any, sent: list[Any] = sent,
                                cls: Any = publisher.msg_type) -> None:
                        sent.append(deserialize_message(msg, cls) if isinstance(msg, bytes)
                                    else copy.deepcopy(msg))

                    patch.setattr(publisher, 'publish', capture)
                    # the identifier sends serialized predictions to the handle directly
                    for ident in getattr(node, 'outputs', ()):
                        for name, its in (('send_torque', ident.torque_publisher),
                                          ('send_external_torque', ident.external_publisher)):
                            if its is publisher:
                                patch.setattr(ident, name, capture)
                yield node
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()


@pytest.fixture(scope='module')
def published() -> Graph:
    """Run the simulator and every identifier in-process on SAMPLES samples."""
    sent: dict[str, list[Any]] = {}
    types: dict[str, Any] = {}
    with recorded(ScaraSimNode, [], sent, types) as sim:
        assert isinstance(sim, ScaraSimNode)
        for _ in range(SAMPLES):
            sim.publish_next()
        samples = list(sent[sim.publisher.topic_name])
    for method in METHODS:
        # As scara-ident run starts them; learning off: it changes no message's shape.
        args = ['-r', f'__ns:=/{method}', '-r', 'joint_states:=/joint_states',
                '-p', f'method:={method}', '-p', 'learn:=false', '-p', 'external_torque:=false']
        with recorded(IdentifierNode, args, sent, types) as identifier:
            assert isinstance(identifier, IdentifierNode)
            for sample in samples:
                identifier.on_joint_state(sample)
            identifier.publish_mse()
    return Graph(types, {topic: msgs[-1] for topic, msgs in sent.items() if msgs})


# ------------------------------------------------------------------ meaning of an element
def dimension_labels(msg: Any) -> list[list[str]]:
    """The labels along each dimension of a ``*MultiArray`` (``'metric:mse,nmse'``)."""
    return [dim.label.split(':', 1)[1].split(',') for dim in msg.layout.dim]


def element_meaning(msg: Any, steps: list[Step]) -> dict[str, str]:
    """What a path's array index stands for: its joint and, for an error array, its metric.

    A JointState's ``position/velocity/effort[i]`` is joint ``name[i]``; element ``k`` of
    ``identification_mse`` is row ``k // stride`` (metric) and column ``k % stride`` (joint
    or ``total``) of its two labelled dimensions.
    """
    field, index = steps[-1]
    if index is None:
        return {}
    if hasattr(msg, 'name') and field in JOINT_STATE_FIELDS:
        return {'joint': msg.name[index]}
    if hasattr(msg, 'layout') and len(msg.layout.dim) == 2:
        metrics, joints = dimension_labels(msg)
        row, column = divmod(index, msg.layout.dim[1].stride)
        return {'metric': metrics[row], 'joint': joints[column]}
    return {}


def metric_named(text: str) -> str | None:
    """The metric of ``identification_mse`` a title names (the most specific one)."""
    words = text.lower().replace('_', ' ')
    if 'validation nmse' in words:
        return 'validation_nmse'
    for metric in ('nmse', 'mse'):
        if re.search(rf'\b{metric}\b', words):
            return metric
    return None


def names(text: str, word: str) -> bool:
    """Whether ``text`` names ``word`` as a whole word (``joint1`` is not in ``joint10``)."""
    return re.search(rf'(?<![A-Za-z0-9_]){re.escape(word)}(?![A-Za-z0-9_])', text) is not None


def method_of(topic: str) -> str | None:
    """The method whose namespace a topic is in (``/ffmw/...`` → ``'FFMW'``)."""
    namespace = topic.split('/')[1]
    return METHODS[namespace].label if namespace in METHODS else None


# ------------------------------------------------------------------ resolving a series
@dataclass(frozen=True)
class Series:
    """A resolved series: the element of a published message it plots."""

    topic: str
    steps: tuple[Step, ...]
    value: float
    meaning: dict[str, str]


def resolve(graph: Graph, topic: str, steps: list[Step]) -> Series:
    """Follow ``steps`` through the last message on ``topic``; raise LayoutError if lost."""
    if topic not in graph.types:
        raise LayoutError(f'no node publishes {topic} (published: {sorted(graph.types)})')
    if topic not in graph.messages:
        raise LayoutError(f'nothing was published on {topic} in {SAMPLES} samples')
    msg_type = graph.types[topic]
    value: Any = graph.messages[topic]
    for field, index in steps:
        fields = type(value).get_fields_and_field_types()
        if field not in fields:
            raise LayoutError(f'{type(value).__name__} has no field {field!r} '
                             f'(fields: {", ".join(fields)})')
        value = getattr(value, field)
        if index is not None:
            if isinstance(value, (str, bytes)) or not hasattr(value, '__len__'):
                raise LayoutError(f'{field} is a {fields[field]}, not an array')
            if index >= len(value):
                raise LayoutError(f'{field}[{index}] is out of range: the published '
                                 f'{msg_type.__name__} has {len(value)} elements')
            value = value[index]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise LayoutError(f'{type(value).__name__} value: not a number to plot')
    meaning = element_meaning(graph.messages[topic], steps)
    return Series(topic, tuple(steps), float(value), meaning)


def parse_fields(text: str) -> list[Step]:
    """``'layout/dim[0]/size'`` split at ``/`` (PlotJuggler) or ``.`` (Foxglove) → steps."""
    steps: list[Step] = []
    for part in re.split(r'[./]', text):
        match = FIELD.fullmatch(part)
        if match is None:
            raise LayoutError(f'{part!r} is not a field name with an optional [index]')
        index = match['index']
        steps.append((match['name'], int(index) if index is not None else None))
    return steps


def check_text(series: Series, text: str) -> list[str]:
    """What ``text`` (a panel title and label) fails to name about the series."""
    missing = []
    metric = series.meaning.get('metric')
    if metric is not None and metric_named(text) != metric:
        missing.append(f'the metric {metric}')
    label = method_of(series.topic)
    if label is not None and not names(text, label):
        missing.append(f'the method {label}')
    return missing


# ------------------------------------------------------------------ Foxglove
def foxglove_tree_panels(node: Any) -> Iterator[str]:
    """Panel ids placed by a Foxglove mosaic tree (a panel id or first/second splits)."""
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for key in ('first', 'second'):
            yield from foxglove_tree_panels(node[key])
    else:
        raise LayoutError(f'not a layout node: {node!r}')


def foxglove_problems(path: Path, graph: Graph) -> tuple[list[str], list[Series]]:
    """Check a Foxglove layout; return its problems and the series it plots."""
    layout = json.loads(path.read_text(encoding='utf-8'))
    configs: dict[str, Any] = layout['configById']
    problems: list[str] = []
    placed: list[str] = []
    pending = list(foxglove_tree_panels(layout['layout']))
    while pending:
        panel = pending.pop()
        placed.append(panel)
        if panel not in configs:
            problems.append(f'{panel} is placed but has no entry in configById')
        elif panel.startswith('Tab!'):
            for tab in configs[panel]['tabs']:
                pending.extend(foxglove_tree_panels(tab['layout']))
    unplaced = sorted(set(configs) - set(placed))
    if unplaced:
        problems.append(f'panels configured but placed nowhere: {unplaced}')
    found: list[Series] = []
    for panel, config in configs.items():
        if not panel.startswith('Plot!'):
            continue
        title = config.get('foxglovePanelTitle', '')
        for entry in config['paths']:
            where = f'{panel}: {entry["value"]!r}'
            match = FOXGLOVE_PATH.fullmatch(entry['value'])
            try:
                if match is None:
                    raise LayoutError('not a /topic.field[index] message path')
                series = resolve(graph, match['topic'], parse_fields(match['fields']))
            except LayoutError as exc:
                problems.append(f'{where}: {exc}')
                continue
            found.append(series)
            stamp = entry.get('timestampMethod')
            if stamp not in FOXGLOVE_STAMPS:
                problems.append(f'{where}: timestampMethod {stamp!r} is none of '
                                f'{FOXGLOVE_STAMPS}')
            elif (stamp == 'headerStamp'
                  and 'header' not in graph.types[series.topic].get_fields_and_field_types()):
                problems.append(f'{where}: headerStamp, but '
                                f'{graph.types[series.topic].__name__} has no header')
            label = entry.get('label', '')
            missing = check_text(series, f'{title} {label}')
            joint = series.meaning.get('joint')
            if joint is not None and not names(label, joint):
                missing.append(f'the joint {joint} (in its label)')
            if missing:
                problems.append(f'{where}: title {title!r} and label {label!r} do not name '
                                + ', '.join(missing))
    return problems, found


# ------------------------------------------------------------------ PlotJuggler
def plotjuggler_series(graph: Graph, name: str) -> Series:
    """Resolve a PlotJuggler series name against the published topics."""
    topics = [t for t in graph.types if name.startswith(t + '/')]
    if not topics:
        raise LayoutError(f'names no published topic (published: {sorted(graph.types)})')
    topic = max(topics, key=len)
    rest = name[len(topic) + 1:]
    if topic not in graph.messages:
        raise LayoutError(f'nothing was published on {topic} in {SAMPLES} samples')
    msg = graph.messages[topic]
    if hasattr(msg, 'name') and set(JOINT_STATE_FIELDS) <= set(
            type(msg).get_fields_and_field_types()):
        # PlotJuggler's JointState parser: /topic/<joint>/<position|velocity|effort>
        joint, _, field = rest.rpartition('/')
        if field not in JOINT_STATE_FIELDS or joint not in msg.name:
            raise LayoutError(f'PlotJuggler names a JointState series /topic/<joint>/<field>, '
                             f'joint one of {list(msg.name)}, field one of '
                             f'{JOINT_STATE_FIELDS}')
        return resolve(graph, topic, [(field, list(msg.name).index(joint))])
    return resolve(graph, topic, parse_fields(rest))


def plotjuggler_problems(path: Path, graph: Graph) -> tuple[list[str], list[Series]]:
    """Check a PlotJuggler layout; return its problems and the series it plots."""
    root = ET.parse(path).getroot()
    problems: list[str] = []
    if root.tag != 'root' or root.find('tabbed_widget') is None:
        problems.append('not a PlotJuggler layout: <root> with a <tabbed_widget> expected')
    for splitter in root.iter('DockSplitter'):
        children = [c for c in splitter if c.tag in ('DockSplitter', 'DockArea')]
        sizes = splitter.get('sizes', '').split(';')
        if not (int(splitter.get('count', '0')) == len(children) == len(sizes)):
            problems.append(f'a DockSplitter of count {splitter.get("count")} has '
                            f'{len(children)} children and sizes {sizes}')
    found: list[Series] = []
    for area in root.iter('DockArea'):
        title = area.get('name', '')
        for curve in area.iter('curve'):
            name = curve.get('name', '')
            try:
                series = plotjuggler_series(graph, name)
            except LayoutError as exc:
                problems.append(f'{name!r}: {exc}')
                continue
            found.append(series)
            missing = check_text(series, title)
            joint = series.meaning.get('joint')
            if series.meaning.get('metric') is None and joint and not names(title, joint):
                missing.append(f'the joint {joint}')
            if missing:
                problems.append(f'{name!r}: its plot {title!r} does not name '
                                + ', '.join(missing))
    return problems, found


CHECKS = {FOXGLOVE: foxglove_problems, PLOTJUGGLER: plotjuggler_problems}


# ------------------------------------------------------------------ the tests
@pytest.mark.parametrize('layout', CHECKS, ids=lambda p: p.name)
def test_every_series_is_a_published_number_named_for_what_it_is(
        layout: Path, published: Graph) -> None:
    problems, found = CHECKS[layout](layout, published)
    assert not problems, '\n'.join(problems)
    assert found


@pytest.mark.parametrize('layout', CHECKS, ids=lambda p: p.name)
def test_every_effort_and_every_error_element_is_plotted(
        layout: Path, published: Graph) -> None:
    _, found = CHECKS[layout](layout, published)
    plotted = {(s.topic, s.steps[-1]) for s in found}
    wanted = set()
    for topic, msg in published.messages.items():
        if hasattr(msg, 'effort'):  # measured and identified efforts, every joint
            wanted |= {(topic, ('effort', i)) for i in range(len(msg.name))}
        elif hasattr(msg, 'layout'):  # every metric of every joint and the total
            wanted |= {(topic, ('data', k)) for k in range(len(msg.data))}
    assert len(wanted) >= 4 * (1 + len(METHODS)) + 15 * len(METHODS)
    assert not wanted - plotted, f'not plotted: {sorted(wanted - plotted)}'


def test_the_error_array_is_laid_out_as_the_layouts_assume(published: Graph) -> None:
    for method in METHODS:
        msg = published.messages[f'/{method}/identification_mse']
        joints = published.messages[f'/{method}/identified_torque'].name
        assert dimension_labels(msg) == [['mse', 'nmse', 'validation_nmse'],
                                         [*joints, 'total']]
        assert [d.size for d in msg.layout.dim] == [3, len(joints) + 1]
        assert len(msg.data) == msg.layout.dim[0].stride == 3 * msg.layout.dim[1].stride


def test_setup_installs_both_layouts_into_share_config(monkeypatch: pytest.MonkeyPatch) -> None:
    arguments: dict[str, Any] = {}
    monkeypatch.setattr('setuptools.setup', arguments.update)  # what setup.py would do
    monkeypatch.chdir(REPO)  # setup.py globs relative to its directory
    runpy.run_path('setup.py')
    installed = dict(arguments['data_files'])['share/scara_ident_ros/config']
    for layout in CHECKS:
        assert f'config/{layout.name}' in installed


# Deliberate mistakes, each in a copy of a shipped layout: the check must report them.
BROKEN = [
    (FOXGLOVE, '"/joint_states.effort[3]"', '"/joint_states.effort[4]"', 'out of range'),
    (FOXGLOVE, '"/ffw/identified_torque.effort[0]"', '"/ffw/identified_torque.efort[0]"',
     "no field 'efort'"),
    (FOXGLOVE, '"/ffs/identified_torque.effort[1]"', '"/ffs/identified_torques.effort[1]"',
     'no node publishes /ffs/identified_torques'),
    (FOXGLOVE, '"/ffmw/identification_mse.data[14]"', '"/ffmw/identification_mse.data[15]"',
     'out of range'),
    (FOXGLOVE, '"/ffmw/identification_mse.data[13]"', '"/ffmw/identification_mse.data[8]"',
     'the metric nmse'),
    (FOXGLOVE, '"/ffw/identification_mse.data[0]"', '"/ffw/identification_mse.data[1]"',
     'the joint joint2'),
    (FOXGLOVE, '"/ffs/identification_mse.data[5]"', '"/ffw/identification_mse.data[5]"',
     'the method FFW'),
    (FOXGLOVE, '"/joint_states.effort[0]"', '"/joint_states.header"', 'not a number'),
    (PLOTJUGGLER, '"/joint_states/joint1/effort"', '"/joint_states/effort[0]"',
     'PlotJuggler names a JointState series'),
    (PLOTJUGGLER, '"/ffmw/identified_torque/joint2/effort"',
     '"/ffmw/identified_torque/joint5/effort"', 'PlotJuggler names a JointState series'),
    (PLOTJUGGLER, '"/ffs/identification_mse/data[14]"', '"/ffs/identification_mse/data[15]"',
     'out of range'),
    (PLOTJUGGLER, '"/ffw/identification_mse/data[10]"', '"/ffw/identification_mse/data[0]"',
     'the metric mse'),
    (PLOTJUGGLER, '"/ffw/identification_mse/data[4]"', '"/ffw/identification_mse.data[4]"',
     'names no published topic'),
]


@pytest.mark.parametrize(('layout', 'good', 'bad', 'reported'), BROKEN,
                         ids=[f'{b[0].suffix[1:]}-{b[2]}' for b in BROKEN])
def test_a_broken_copy_is_reported(layout: Path, good: str, bad: str, reported: str,
                                   published: Graph, tmp_path: Path) -> None:
    text = layout.read_text(encoding='utf-8')
    assert good in text
    broken = tmp_path / layout.name
    broken.write_text(text.replace(good, bad, 1), encoding='utf-8')
    problems, _ = CHECKS[layout](broken, published)
    assert any(bad.strip('"') in p and reported in p for p in problems), problems


def test_a_foxglove_header_stamp_on_a_message_without_header_is_reported(
        published: Graph, tmp_path: Path) -> None:
    layout = json.loads(FOXGLOVE.read_text(encoding='utf-8'))
    plot = next(c for c in layout['configById'].values()
                if any('identification_mse' in p['value'] for p in c.get('paths', [])))
    plot['paths'][0]['timestampMethod'] = 'headerStamp'
    broken = tmp_path / FOXGLOVE.name
    broken.write_text(json.dumps(layout), encoding='utf-8')
    problems, _ = foxglove_problems(broken, published)
    assert any('Float64MultiArray has no header' in p for p in problems), problems


def test_a_foxglove_panel_placed_nowhere_is_reported(
        published: Graph, tmp_path: Path) -> None:
    layout = json.loads(FOXGLOVE.read_text(encoding='utf-8'))
    layout['configById']['Plot!orphan'] = {'paths': []}
    broken = tmp_path / FOXGLOVE.name
    broken.write_text(json.dumps(layout), encoding='utf-8')
    problems, _ = foxglove_problems(broken, published)
    assert any('Plot!orphan' in p for p in problems), problems
