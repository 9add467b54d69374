"""The paper's comparison of FFMW, FFW and FFS on simulated data or a recording
(``scara-ident compare [--recording FILE]``).

Data (simulator core, 1 kHz, no noise, no disturbance unless the code is changed):

* a training run on one random excitation (``--train-seed``) and a held-out run on another
  (``--test-seed``), both of the ``--preset`` kind;
* offline (Table 2 analog): ``--samples`` samples drawn at random from the first
  ``--train-seconds`` of the training run, inputs q, q', and the simulator's *true* q''
  (``--acceleration estimated`` uses q'' estimated from q' instead);
* online (Table 3 analog): the first ``--online-seconds`` of the training run as a stream,
  q'' estimated from q' by the identifier's input stage (zero-phase, centred);
* learning curves: ``--curve-seconds`` of the identifier's default stream (``sequence``)
  per seed, learnt online by each method with each trainer (``lm``, the identifier's
  default, and the paper's ``bp``) through the identifier's own pipeline; the frozen model
  scored at checkpoints on excitations never streamed, with LS and recursive LS on the
  physical regressor as references (``fig_learning_curves.png``);
* hyperparameters: per method, a grid search of learning rate, momentum and initial weight
  scale on the first ``--search-seconds`` of the stream (training data only), see
  :mod:`scara_ident_ros.paper.hyperparameters`; the choice is used by both tables.

With ``--recording FILE`` (anything ``scara-ident train`` reads: a rosbag2 or ROS 1 bag, a
CSV export of /joint_states, an .npz or CSV table, ``FILE.npz:SPLIT``) the data are that
recording's samples, split as ``train`` splits them
(:func:`~scara_ident_ros.identification.split.block_split`: ``--validation-fraction`` of
its ``--validation-block`` time blocks, spread over the run, drawn with ``--train-seed``):

* held-out: the validation blocks, for both tables;
* offline: ``--samples`` samples drawn from the training blocks (the first
  ``--train-seconds`` of them if given), with the recording's q'' (a table's as given,
  else estimated by the input stage);
* online: the training blocks in time order as the stream (the first ``--online-seconds``
  if given), scaled by their own ranges (the robot's limits are not known);
* no learning curves (they simulate the SCARA);
* the reference row: the SCARA's least squares if the joints are the SCARA's, else linear
  least squares on simple features (:mod:`scara_ident_ros.paper.linear_reference`).

Every network is trained from ``--seeds`` seeds of its initial weights; tables show the median
and [min–max] over seeds. A least-squares fit of the SCARA's linear-in-parameters model is the
model-based reference row.

Writes to ``--out DIR``: ``tables.md`` (what is printed), ``table2.csv`` and ``table3.csv``
(one line per method, seed and data set), ``search.csv`` (every grid point's score),
``fig_learning_curves.png`` and ``conditions.json`` (sizes, seeds, settings, timings,
versions).

BLAS runs on one thread (:mod:`~scara_ident_ros.blas_threads`): the 684 × 684 LM systems
gain nothing from more, and two threads slow trainings down on a shared machine
(docs/results.md). ``--quick`` runs in seconds (for tests).
"""
from __future__ import annotations

import csv
import json
import os
import platform
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.split import VALIDATION_BLOCK_S, VALIDATION_FRACTION
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
from scara_ident_ros.paper.hyperparameters import (DEFAULT_GRID, QUICK_GRID, Grid, Hyperparameters,
                                                   SearchResult, search)
from scara_ident_ros.paper.learning_curves import curves_markdown, run_curves
from scara_ident_ros.paper.table2 import run_offline
from scara_ident_ros.paper.table3 import hold_rows, run_online, stream_data_names
from scara_ident_ros.paper.linear_reference import (linear_reference_rows,
                                                     online_linear_reference_rows)
from scara_ident_ros.paper.reference import is_scara, online_reference_rows, reference_rows
from scara_ident_ros.paper.rows import ResultRow, summarise
from scara_ident_ros.paper.tables import (PAPER_NOTE, format_value, joint_markdown,
                                          offline_markdown, online_markdown, ranking_text,
                                          write_csv)
from scara_ident_ros.identification import DIFFERENTIATOR_WINDOW, PAPER_WINDOW, TRAINERS
from scara_ident_ros.nn.presets import limit_scaling
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.blas_threads import BLAS_THREADS, single_blas_thread
from scara_ident_ros.paper.figures import plot_learning_curves
from scara_ident_ros.paper.software_versions import software_versions

__all__ = ['HELD_OUT', 'CompareSettings', 'run_comparison']

HELD_OUT = 'held-out'
#: Settings that a recording (or a simulation) does not use, left out of its conditions.
_SIMULATION_ONLY = ('test_seconds', 'curve_seconds', 'acceleration', 'preset', 'test_seed')
_RECORDING_ONLY = ('recording', 'topic', 'joints', 'validation_fraction', 'validation_block')


@dataclass(frozen=True)
class CompareSettings:
    """What ``scara-ident compare`` runs (each field is the option of the same name).

    Durations in s of simulated time at 1 kHz; ``seeds`` is a count (seeds 0 .. seeds−1).
    With ``recording`` (a path, ``FILE.npz:SPLIT`` allowed) the data come from it (module
    docstring): ``train_seconds`` and ``online_seconds`` may be ``inf`` (the whole training
    part), ``test_seconds``, ``preset``, ``test_seed``, ``acceleration`` and
    ``curve_seconds`` are not used, ``train_seed`` draws the validation blocks.
    """

    seeds: int
    train_seconds: float
    test_seconds: float
    online_seconds: float
    search_seconds: float
    iterations: int
    samples: int
    window: int
    curve_seconds: float
    goal: float
    acceleration: str
    methods: tuple[str, ...]
    preset: str
    train_seed: int
    test_seed: int
    search: bool
    quick: bool
    out: Path
    recording: str | None = None
    topic: str | None = None
    joints: tuple[str, ...] | None = None
    validation_fraction: float = VALIDATION_FRACTION
    validation_block: float = VALIDATION_BLOCK_S

    @property
    def grid(self) -> Grid:
        """The hyperparameter grid searched."""
        return QUICK_GRID if self.quick else DEFAULT_GRID

    @property
    def search_seeds(self) -> tuple[int, ...]:
        """Seeds of each grid point."""
        return (0,) if self.quick else (0, 1)


def run_comparison(s: CompareSettings, *,
                   progress: Callable[[str], None] = lambda line: None) -> str:
    """Run the comparison, write its files into ``s.out``; return ``tables.md``'s text.

    Raises
    ------
    ScaraIdentError
        If the simulation refuses the settings or ``s.out`` cannot be written.
    """
    with single_blas_thread():
        return _run(s, progress)


class _Data(NamedTuple):
    """The comparison's data sets, wherever they come from."""

    names: tuple[str, ...]
    offline_pool: Dataset
    offline_train: Dataset
    offline_test: Dataset
    stream: Dataset
    online_test: Dataset
    scaling: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    scara: bool  # the SCARA's least-squares reference applies
    source: dict[str, Any]  # what the report and conditions.json say about the data


def _head(data: Dataset, seconds: float, name: str) -> Dataset:
    return data.head(seconds, name) if np.isfinite(seconds) else data.take(slice(None), name)


def _simulated(s: CompareSettings, params: ScaraParams) -> _Data:
    run_seconds = max(s.train_seconds, s.online_seconds)
    try:
        train_rec = simulate_record(params, seconds=run_seconds, seed=s.train_seed,
                                    preset=s.preset)
        test_rec = simulate_record(params, seconds=s.test_seconds, seed=s.test_seed,
                                   preset=s.preset)
    except (ValueError, OverflowError) as exc:
        raise ScaraIdentError(str(exc)) from None
    offline_pool = dataset_from_record(train_rec, acceleration=s.acceleration,
                                       name='train').head(s.train_seconds)
    scaling = limit_scaling(params.position_min, params.position_max, params.velocity_max,
                            params.acceleration_max, params.effort_max)
    return _Data(
        tuple(params.joint_names), offline_pool,
        offline_pool.subsample(s.samples, seed=s.train_seed),
        dataset_from_record(test_rec, acceleration=s.acceleration, name=HELD_OUT),
        dataset_from_record(train_rec, acceleration='estimated',
                            name='stream').head(s.online_seconds),
        dataset_from_record(test_rec, acceleration='estimated', name=HELD_OUT), scaling,
        True, {'kind': 'simulation', 'simulated': f'{len(train_rec)} + {len(test_rec)}',
               'simulation': 'SimConfig() defaults: no noise, no disturbance, no model '
                             'mismatch',
               'offline_acceleration': s.acceleration, 'online_scaling':
               'robot joint limits (methods.limit_scaling)', 'sample_rate_hz': 1000.0})


def _recorded(s: CompareSettings) -> _Data:
    from scara_ident_ros.identification.recording import load_recording, skipped_text
    from scara_ident_ros.identification.split import block_split

    assert s.recording is not None
    recording = load_recording(Path(s.recording), topic=s.topic, joints=s.joints)
    samples = recording.samples.data
    try:
        train, held_out = block_split(samples, s.validation_fraction,
                                      block_s=s.validation_block, seed=s.train_seed)
    except ValueError as exc:
        raise ScaraIdentError(f'{s.recording}: {exc}; lower --validation-block') from None
    if len(train) < 2 or len(held_out) < 1:
        raise ScaraIdentError(f'{s.recording}: {len(train)} training and {len(held_out)} '
                              'held-out samples; the comparison needs both')
    offline_pool = _head(train, s.train_seconds, 'train')
    stream = _head(train, s.online_seconds, 'stream')
    names = tuple(recording.samples.names)
    held_out = held_out.take(slice(None), HELD_OUT)
    steps = np.diff(samples.stamp_ns) * 1e-9
    return _Data(
        names, offline_pool, offline_pool.subsample(s.samples, seed=s.train_seed), held_out,
        stream, held_out, _data_scaling(stream), is_scara(names, samples.X),
        {'kind': 'recording', 'recording': str(s.recording), 'topic': recording.topic,
         'joints': list(names), 'samples': len(samples), 'seconds': round(samples.seconds, 3),
         'skipped': skipped_text(recording.samples),
         'median_step_ms': round(float(np.median(steps)) * 1e3, 3) if steps.size else None,
         'validation_fraction': s.validation_fraction,
         'validation_block_s': s.validation_block, 'split_seed': s.train_seed,
         'offline_acceleration': samples.acceleration,
         'online_scaling': "min-max of the stream's q, |q'|, |q''| and |effort|",
         'sample_rate_hz': round(1.0 / float(np.median(steps)), 1) if steps.size else None})


def _data_scaling(data: Dataset) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ranges of a stream for the online networks (there are no limits to take them from)."""
    n = data.n_joints
    q = data.X[:, :n]
    low, high = q.min(axis=0), q.max(axis=0)
    flat = high - low == 0.0
    low, high = np.where(flat, low - 1.0, low), np.where(flat, high + 1.0, high)
    peaks = [np.abs(a).max(axis=0) for a in (data.X[:, n:2 * n], data.X[:, 2 * n:], data.Y)]
    peaks = [np.where(p > 0.0, p, 1.0) for p in peaks]
    return limit_scaling(low, high, *peaks)


def _run(s: CompareSettings, say: Callable[[str], None]) -> str:
    started, cpu_started = time.perf_counter(), time.process_time()
    timings: dict[str, float] = {}
    params = ScaraParams()
    seeds = list(range(s.seeds))
    methods = list(s.methods)

    tick = time.perf_counter()
    data = _recorded(s) if s.recording is not None else _simulated(s, params)
    offline_pool, offline_train, offline_test = (data.offline_pool, data.offline_train,
                                                 data.offline_test)
    stream, online_test, scaling = data.stream, data.online_test, data.scaling
    segment = stream.head(s.search_seconds, name='search')
    window = min(s.window, len(stream))
    timings['data' if s.recording is not None else 'simulation'] = time.perf_counter() - tick
    if s.recording is not None:
        say(f'{s.recording}: {data.source["samples"]} samples of {len(data.names)} joints; '
            f'training part {len(offline_pool)}, held-out {len(offline_test)} samples')
    else:
        say(f'simulated {data.source["simulated"]} samples in '
            f'{timings["simulation"]:.1f} s')

    tick = time.perf_counter()
    searches: list[SearchResult] = []
    hyper: dict[str, Hyperparameters] = {}
    for name in methods:
        if s.search:
            result = search(name, segment.X, segment.Y, scaling=scaling, grid=s.grid,
                            seeds=s.search_seeds)
            searches.append(result)
            hyper[name] = result.best
            say(f'search {method_spec(name).label}: {result.best}')
        else:
            hyper[name] = Hyperparameters.defaults(name)
    timings['search'] = time.perf_counter() - tick

    tick = time.perf_counter()
    offline = run_offline(offline_train.X, offline_train.Y,
                          {HELD_OUT: (offline_test.X, offline_test.Y)}, methods=methods,
                          seeds=seeds, iterations=s.iterations, goal=s.goal,
                          hyperparameters=hyper, progress=say)
    if data.scara:
        offline += reference_rows(offline_train.X, offline_train.Y,
                                  {HELD_OUT: (offline_test.X, offline_test.Y)},
                                  coulomb_eps=params.coulomb_eps)
    else:
        offline += linear_reference_rows(offline_train.X, offline_train.Y,
                                         {HELD_OUT: (offline_test.X, offline_test.Y)})
    timings['offline'] = time.perf_counter() - tick

    tick = time.perf_counter()
    online = run_online(stream.X, stream.Y, {HELD_OUT: (online_test.X, online_test.Y)},
                        scaling=scaling, methods=methods, seeds=seeds, hyperparameters=hyper,
                        window=window, progress=say)
    if data.scara:
        online += online_reference_rows(stream.X, stream.Y,
                                        {HELD_OUT: (online_test.X, online_test.Y)},
                                        window=window, coulomb_eps=params.coulomb_eps)
    else:
        online += online_linear_reference_rows(stream.X, stream.Y,
                                               {HELD_OUT: (online_test.X, online_test.Y)},
                                               window=window)
    online += hold_rows(stream.Y, window=window)
    timings['online'] = time.perf_counter() - tick

    tick = time.perf_counter()
    curves = []
    if s.curve_seconds > 0 and s.recording is None:
        say(f'learning curves: {s.curve_seconds:g} s of stream, {len(seeds)} seeds, '
             f'trainers {", ".join(TRAINERS)} (two worker processes)')
        curves = run_curves(params, seeds=seeds, methods=methods, trainers=TRAINERS,
                            seconds=s.curve_seconds,
                            held_out_s=(1.0, 2.0) if s.quick else (6.0, 30.0))
    timings['curves'] = time.perf_counter() - tick
    timings['total'] = time.perf_counter() - started
    timings['total_cpu'] = time.process_time() - cpu_started

    conditions = _conditions(s, seeds, methods, hyper, searches, timings,
                             {'offline training pool': offline_pool,
                              'offline training (LM)': offline_train,
                              'offline held-out': offline_test, 'online stream': stream,
                              'online held-out': online_test, 'search segment': segment},
                             window, data)
    text = _report(offline, online, searches, hyper, conditions, window)
    if curves:
        text += ('\n## Learning curves: frozen models on motions never seen\n\n'
                 f'{s.curve_seconds:g} s of the identifier\'s default stream (`sequence`) '
                 'per seed, learnt online through the identifier\'s pipeline (zero-phase '
                 "q'', 10 % held back) by each trainer (`lm`: the identifier's default; "
                 '`bp`: the paper\'s per-sample back-propagation, the method\'s default '
                 'rates); the frozen model scored on 5 `standard` excitations and 30 s of '
                 'another `sequence` never streamed. LS and RLS: the physical regressor '
                 'fitted to the same stream inputs. Figure: `fig_learning_curves.png`.\n\n'
                 + curves_markdown(curves) + '\n')
    out = s.out
    try:
        out.mkdir(parents=True, exist_ok=True)
        if curves:
            plot_learning_curves(out / 'fig_learning_curves.png', curves)
        names = list(data.names)
        write_csv(out / 'table2.csv', offline, joint_names=names)
        write_csv(out / 'table3.csv', online, joint_names=names)
        _write_search_csv(out / 'search.csv', searches)
        (out / 'tables.md').write_text(text, encoding='utf-8')
        (out / 'conditions.json').write_text(json.dumps(conditions, indent=1) + '\n',
                                             encoding='utf-8')
    except OSError as exc:
        raise ScaraIdentError(f'cannot write to {out}: {exc.strerror or exc}') from None
    say(f'wrote {out}/tables.md, table2.csv, table3.csv, search.csv, conditions.json '
         f'({timings["total"]:.0f} s)')
    return text


# ------------------------------------------------------------------------------- report
def _report(offline: list[ResultRow], online: list[ResultRow], searches: list[SearchResult],
            hyper: dict[str, Hyperparameters], conditions: dict[str, Any], window: int) -> str:
    summaries = summarise(offline + online)
    labels = [method_spec(m).label for m in hyper]
    c = conditions
    short, long = stream_data_names(window, PAPER_WINDOW)
    text = _texts(c, window)
    parts = [text['title'], text['data'] + ' Cells are median [min–max] over seeds. MSE is '
             f'the mean over the {len(c["joints"])} joints of the per-joint MSE in physical '
             'units ((N·m)², N²); NMSE is the mean over joints of MSE_j / var(effort_j), var '
             'over the same samples: NMSE = 1 is no better than predicting the mean effort '
             'of those samples.\n',
             f'Wall time {c["timings_s"]["total"]:.0f} s, CPU time '
             f'{c["timings_s"]["total_cpu"]:.0f} s; BLAS threads: {c["blas_threads"]}.\n']
    parts += ['## Hyperparameters\n', _search_markdown(searches, hyper)]
    parts += [
        '## Table 2 analog: offline, Levenberg–Marquardt\n',
        text['offline'] +
        f'{c["iterations"]} iterations each. Goal: training MSE of the outputs scaled to '
        f'[-1, 1] by the training data\'s min–max (as MATLAB\'s mapminmax) <= {c["goal"]:g}; '
        "'goal reached' gives the runs reaching it and the iterations they needed. LS: "
        f'{c["reference"]}, fitted on the same samples.\n',
        offline_markdown(summaries, test=HELD_OUT), 'Held-out NMSE per joint:\n',
        joint_markdown(summaries, table='offline', data=HELD_OUT, joint_names=c['joints']),
        ranking_text(summaries, 'offline', [('train', 'mse_mean', 'training MSE'),
                                            (HELD_OUT, 'nmse_mean', 'held-out NMSE')],
                     labels),
        '## Table 3 analog: online, one back-propagation step per sample\n',
        text['online'] + ' Each sample is predicted before it is learnt; '
        f'`{short}` is the paper\'s "error over the last {PAPER_WINDOW} samples", '
        f'`{long}` the last {window} samples; held-out: predict-only on the held-out '
        f'{text["held_out"]} after the stream. The effort varies little within '
        f'{PAPER_WINDOW} samples, so the NMSE over them is a noisy figure; `{long}` '
        f'is the steadier one. LS: {c["reference"]}, fitted on the stream before the '
        'windows, with the same q\'\'. hold: no model, each effort predicted as the '
        'previous sample\'s; an online error is only worth something below it.\n',
        online_markdown(summaries, short=short, long=long, test=HELD_OUT),
        'Held-out NMSE per joint:\n',
        joint_markdown(summaries, table='online', data=HELD_OUT, joint_names=c['joints']),
        ranking_text(summaries, 'online', [(short, 'mse_mean', f'{short} MSE'),
                                           (long, 'nmse_mean', f'{long} NMSE'),
                                           (HELD_OUT, 'nmse_mean', 'held-out NMSE')],
                     labels),
        f'**Paper\'s numbers.** {PAPER_NOTE}\n\n',
        '## Conditions\n', _conditions_markdown(c)]
    return '\n'.join(parts)


def _texts(c: dict[str, Any], window: int) -> dict[str, str]:
    """The paragraphs of the report that say where the data come from."""
    sizes = c['data']
    src = c['source']
    n = len(c['joints'])
    if src['kind'] == 'simulation':
        return {
            'title': "# scara-ident compare: the paper's Tables 2 and 3 on simulated data\n",
            'data': f'Simulated SCARA at 1 kHz, `{c["preset"]}` excitations, no noise or '
                    f'disturbance; training run seed {c["train_seed"]}, held-out run seed '
                    f'{c["test_seed"]}; networks {c["network"]} from seeds {c["seeds"]}.',
            'offline': f'{sizes["offline training (LM)"]["samples"]} training samples drawn '
                       f'from the first {c["train_seconds"]:g} s of the training run; '
                       f'held-out: {sizes["offline held-out"]["samples"]} samples '
                       f'({c["test_seconds"]:g} s). q\'\' is the '
                       f'{_acceleration_text(c["offline_acceleration"])}. ',
            'online': f'Stream: the first {c["online_seconds"]:g} s of the training run '
                      f'({sizes["online stream"]["samples"]} samples), q\'\' estimated from '
                      "q' by the identifier's input stage (zero-phase); scaling from the "
                      "robot's joint limits.",
            'held_out': 'run'}
    del window
    accel = ("q'' as the table gives it" if src['offline_acceleration'] == 'true'
             else "q'' estimated from q' by the identifier's input stage (zero-phase)")
    return {
        'title': "# scara-ident compare: the paper's Tables 2 and 3 on a recording\n",
        'data': f'Recording `{src["recording"]}` ({src["topic"]}): {src["samples"]} usable '
                f'samples of {n} joints ({", ".join(c["joints"])}) over {src["seconds"]:g} s, '
                f'median step {src["median_step_ms"]} ms (skipped: {src["skipped"]}). '
                f'Held-out: the validation blocks, {src["validation_fraction"]:g} of the '
                f'{src["validation_block_s"]:g} s blocks spread over the run (one drawn with '
                f'seed {src["split_seed"]} from each stretch), as `scara-ident train` splits; '
                f'{sizes["offline held-out"]["samples"]} samples. Networks {c["network"]} '
                f'from seeds {c["seeds"]}.',
        'offline': f'{sizes["offline training (LM)"]["samples"]} training samples drawn from '
                   f'the {sizes["offline training pool"]["samples"]} samples of the training '
                   f'blocks; {accel}. ',
        'online': f'Stream: the training blocks in time order '
                  f'({sizes["online stream"]["samples"]} samples), {accel}; scaling from '
                  "the stream's own ranges (no joint limits are known).",
        'held_out': 'blocks'}


def _acceleration_text(kind: str) -> str:
    return ("simulator's true acceleration" if kind == 'true'
            else "zero-phase estimate from q' (the identifier's input stage)")


def _search_markdown(searches: list[SearchResult], hyper: dict[str, Hyperparameters]) -> str:
    chosen = '\n'.join(f'- {method_spec(m).label}: {h}' for m, h in hyper.items())
    if not searches:
        return ('No search (`--no-search`): the METHODS defaults.\n\n' + chosen + '\n')
    first = searches[0]
    grid = _grid_of(searches)
    head = (f'Grid search per method on the first {first.n_samples} samples of the training '
            f'stream (training data only; procedure in '
            f'`scara_ident_ros.paper.hyperparameters`). Each grid point, from seeds '
            f'{list(first.seeds)}, learns the first {first.n_samples - first.n_scored} '
            f'samples online; then over the last {first.n_scored}: **a priori** = NMSE of '
            f'its predictions made before learning each sample (the score, worst seed), '
            f'**frozen** = NMSE of a copy frozen at the split (reported, not used). Eligible '
            f'(`*` chosen, `+` eligible): the point and the next larger learning rate both '
            f'have a-priori NMSE < 1 for every seed. inf = diverged. Grid: learning_rate '
            f'{list(grid.learning_rate)} × momentum {list(grid.momentum)} × weight_scale '
            f'{list(grid.weight_scale)} = {grid.size} points.\n\n')
    labels = [method_spec(r.method).label for r in searches]
    lines = ['| learning_rate | momentum | weight_scale | '
             + ' | '.join(f'{m} a priori | {m} frozen' for m in labels) + ' |',
             '|---|---|---|' + '---|---|' * len(labels)]
    for i, point in enumerate(searches[0].trials):
        h = point.hyperparameters
        cells = []
        for r in searches:
            trial = r.trials[i]
            mark = ('*' if trial.hyperparameters == r.best else '+' if trial.eligible
                    else '')
            cells += [f'{mark}{format_value(trial.score)}',
                      format_value(trial.frozen)]
        lines.append(f'| {h.learning_rate:g} | {h.momentum:g} | {h.weight_scale:g} | '
                     + ' | '.join(cells) + ' |')
    return head + '\n'.join(lines) + '\n\nChosen (used by both tables):\n\n' + chosen + '\n'


def _grid_of(searches: list[SearchResult]) -> Grid:
    points = [t.hyperparameters for t in searches[0].trials]
    return Grid(tuple(dict.fromkeys(p.learning_rate for p in points)),
                tuple(dict.fromkeys(p.momentum for p in points)),
                tuple(dict.fromkeys(p.weight_scale for p in points)))


def _write_search_csv(path: Path, searches: list[SearchResult]) -> None:
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.writer(stream, lineterminator='\n')
        seeds = list(searches[0].seeds) if searches else []
        writer.writerow(['method', 'learning_rate', 'momentum', 'weight_scale', 'score',
                         *(f'score_seed{seed}' for seed in seeds), 'frozen',
                         *(f'frozen_seed{seed}' for seed in seeds), 'diverged', 'eligible',
                         'chosen', 'seconds'])
        for r in searches:
            for t in r.trials:
                h = t.hyperparameters
                writer.writerow([method_spec(r.method).label, h.learning_rate, h.momentum,
                                 h.weight_scale, repr(t.score), *map(repr, t.scores),
                                 repr(t.frozen), *map(repr, t.frozen_scores), t.diverged,
                                 t.eligible, h == r.best, f'{t.seconds:.3f}'])


# --------------------------------------------------------------------------- conditions
def _conditions(s: CompareSettings, seeds: list[int], methods: list[str],
                hyper: dict[str, Hyperparameters], searches: list[SearchResult],
                timings: dict[str, float], data: dict[str, Dataset],
                window: int, source: _Data) -> dict[str, Any]:
    n = len(source.names)
    return {
        'options': {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(s).items()
                    if k not in (_SIMULATION_ONLY if s.recording else _RECORDING_ONLY)},
        'quick': bool(s.quick),
        'preset': s.preset, 'train_seed': s.train_seed, 'test_seed': s.test_seed,
        'seeds': seeds, 'methods': [method_spec(m).label for m in methods],
        'train_seconds': s.train_seconds, 'test_seconds': s.test_seconds,
        'online_seconds': s.online_seconds, 'search_seconds': s.search_seconds,
        'iterations': s.iterations, 'samples': s.samples, 'goal': s.goal,
        'goal_units': 'training MSE of outputs scaled to [-1, 1] by the training min-max',
        'online_window': window, 'paper_window': PAPER_WINDOW,
        'offline_acceleration': source.source['offline_acceleration'],
        'online_acceleration': source.source['offline_acceleration']
        if source.source['kind'] == 'recording' else 'estimated',
        'differentiator': f'centred, window {DIFFERENTIATOR_WINDOW}, degree 2 (identifier '
                          'default, zero-phase)',
        'offline_scaling': 'min-max of the LM training samples',
        'online_scaling': source.source['online_scaling'],
        'network': f'{3 * n}-40-{n}', 'sample_rate_hz': source.source['sample_rate_hz'],
        'joints': list(source.names), 'source': source.source,
        'reference': ('least squares on the SCARA\'s 14 base parameters' if source.scara
                      else 'linear least squares on [q, q\', q\'\', sin q, cos q, '
                      'tanh(q\'/0.05), 1]'),
        'data': {name: {'samples': len(d), 'seconds': round(d.seconds, 3),
                        'acceleration': d.acceleration} for name, d in data.items()},
        'search': None if not searches else {
            'grid': {'learning_rate': list(_grid_of(searches).learning_rate),
                     'momentum': list(_grid_of(searches).momentum),
                     'weight_scale': list(_grid_of(searches).weight_scale)},
            'segment_samples': searches[0].n_samples,
            'scored_samples': searches[0].n_scored, 'seeds': list(searches[0].seeds),
            'score': 'worst over seeds of the joint-mean NMSE of the a-priori predictions '
                     'of the scored samples, after learning the others online; eligible '
                     'only if the next larger learning rate is stable',
            'frozen': 'reported only: NMSE of the network frozen before the scored samples'},
        'hyperparameters': {method_spec(m).label: {'learning_rate': h.learning_rate,
                                                   'momentum': h.momentum,
                                                   'weight_scale': h.weight_scale}
                            for m, h in hyper.items()},
        'timings_s': {k: round(v, 2) for k, v in timings.items()},
        'blas_threads': BLAS_THREADS,
        'versions': software_versions(),
        'machine': {'platform': platform.platform(), 'cpus': os.cpu_count()},
    }


def _conditions_markdown(c: dict[str, Any]) -> str:
    lines = ['- options: ' + ', '.join(f'{k}={v}' for k, v in c['options'].items()),
             '- data: ' + '; '.join(f'{k} {v["samples"]} samples ({v["seconds"]:g} s, '
                                     f'q\'\' {v["acceleration"]})'
                                     for k, v in c['data'].items()),
             f'- seeds {c["seeds"]}; LM {c["iterations"]} iterations, goal {c["goal"]:g} '
             f'({c["goal_units"]})',
             '- timings (s): ' + ', '.join(f'{k} {v:g}' for k, v in c['timings_s'].items()),
             '- versions: ' + ', '.join(f'{k} {v}' for k, v in c['versions'].items()),
             f'- machine: {c["machine"]["platform"]}, {c["machine"]["cpus"]} CPUs']
    return '\n'.join(lines) + '\n'

