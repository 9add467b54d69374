"""The paper's comparison of FFMW, FFW and FFS on simulated data (``scara-ident compare``).

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
from typing import Any

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.paper.datasets import dataset_from_record, simulate_record
from scara_ident_ros.paper.hyperparameters import (DEFAULT_GRID, QUICK_GRID, Grid, Hyperparameters,
                                                   SearchResult, search)
from scara_ident_ros.paper.learning_curves import curves_markdown, run_curves
from scara_ident_ros.paper.table2 import run_offline
from scara_ident_ros.paper.table3 import hold_rows, run_online, stream_data_names
from scara_ident_ros.paper.reference import online_reference_rows, reference_rows
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


@dataclass(frozen=True)
class CompareSettings:
    """What ``scara-ident compare`` runs (each field is the option of the same name).

    Durations in s of simulated time at 1 kHz; ``seeds`` is a count (seeds 0 .. seeds−1).
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


def _run(s: CompareSettings, say: Callable[[str], None]) -> str:
    started, cpu_started = time.perf_counter(), time.process_time()
    timings: dict[str, float] = {}
    params = ScaraParams()
    seeds = list(range(s.seeds))
    methods = list(s.methods)

    tick = time.perf_counter()
    run_seconds = max(s.train_seconds, s.online_seconds)
    try:
        train_rec = simulate_record(params, seconds=run_seconds, seed=s.train_seed,
                                    preset=s.preset)
        test_rec = simulate_record(params, seconds=s.test_seconds, seed=s.test_seed,
                                   preset=s.preset)
    except ValueError as exc:
        raise ScaraIdentError(str(exc)) from None
    offline_pool = dataset_from_record(train_rec, acceleration=s.acceleration,
                                       name='train').head(s.train_seconds)
    offline_train = offline_pool.subsample(s.samples, seed=s.train_seed)
    offline_test = dataset_from_record(test_rec, acceleration=s.acceleration,
                                       name=HELD_OUT)
    stream = dataset_from_record(train_rec, acceleration='estimated',
                                 name='stream').head(s.online_seconds)
    online_test = dataset_from_record(test_rec, acceleration='estimated', name=HELD_OUT)
    segment = stream.head(s.search_seconds, name='search')
    window = min(s.window, len(stream))
    timings['simulation'] = time.perf_counter() - tick
    say(f'simulated {len(train_rec)} + {len(test_rec)} samples in '
         f'{timings["simulation"]:.1f} s')
    scaling = limit_scaling(params.position_min, params.position_max, params.velocity_max,
                            params.acceleration_max, params.effort_max)

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
    offline += reference_rows(offline_train.X, offline_train.Y,
                              {HELD_OUT: (offline_test.X, offline_test.Y)},
                              coulomb_eps=params.coulomb_eps)
    timings['offline'] = time.perf_counter() - tick

    tick = time.perf_counter()
    online = run_online(stream.X, stream.Y, {HELD_OUT: (online_test.X, online_test.Y)},
                        scaling=scaling, methods=methods, seeds=seeds, hyperparameters=hyper,
                        window=window, progress=say)
    online += online_reference_rows(stream.X, stream.Y,
                                    {HELD_OUT: (online_test.X, online_test.Y)},
                                    window=window, coulomb_eps=params.coulomb_eps)
    online += hold_rows(stream.Y, window=window)
    timings['online'] = time.perf_counter() - tick

    tick = time.perf_counter()
    curves = []
    if s.curve_seconds > 0:
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
                             window)
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
        names = list(params.joint_names)
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
    parts = ['# scara-ident compare: the paper\'s Tables 2 and 3 on simulated data\n',
             f'Simulated SCARA at 1 kHz, `{c["preset"]}` excitations, no noise or '
             f'disturbance; training run seed {c["train_seed"]}, held-out run seed '
             f'{c["test_seed"]}; networks 12-40-4 from seeds {c["seeds"]}; cells are '
             'median [min–max] over seeds. MSE is the mean over the 4 joints of the '
             'per-joint MSE in physical units ((N·m)², N²); NMSE is the mean over joints of '
             'MSE_j / var(effort_j), var over the same samples: NMSE = 1 is no better '
             'than predicting the mean effort of those samples.\n',
             f'Wall time {c["timings_s"]["total"]:.0f} s, CPU time '
             f'{c["timings_s"]["total_cpu"]:.0f} s; BLAS threads: {c["blas_threads"]}.\n']
    parts += ['## Hyperparameters\n', _search_markdown(searches, hyper)]
    sizes = c['data']
    parts += [
        '## Table 2 analog: offline, Levenberg–Marquardt\n',
        f'{sizes["offline training (LM)"]["samples"]} training samples drawn from the first '
        f'{c["train_seconds"]:g} s of the training run; held-out: '
        f'{sizes["offline held-out"]["samples"]} samples ({c["test_seconds"]:g} s). '
        f"q'' is the {_acceleration_text(c['offline_acceleration'])}. "
        f'{c["iterations"]} iterations each. Goal: training MSE of the outputs scaled to '
        f'[-1, 1] by the training data\'s min–max (as MATLAB\'s mapminmax) <= {c["goal"]:g}; '
        "'goal reached' gives the runs reaching it and the iterations they needed. LS: "
        'least squares on the 14 base parameters, fitted on the same samples.\n',
        offline_markdown(summaries, test=HELD_OUT), 'Held-out NMSE per joint:\n',
        joint_markdown(summaries, table='offline', data=HELD_OUT),
        ranking_text(summaries, 'offline', [('train', 'mse_mean', 'training MSE'),
                                            (HELD_OUT, 'nmse_mean', 'held-out NMSE')],
                     labels),
        '## Table 3 analog: online, one back-propagation step per sample\n',
        f'Stream: the first {c["online_seconds"]:g} s of the training run '
        f'({sizes["online stream"]["samples"]} samples), q\'\' estimated from q\' by the '
        "identifier's input stage (zero-phase); scaling from the robot's joint "
        'limits. Each sample is predicted before it is learnt; '
        f'`{short}` is the paper\'s "error over the last {PAPER_WINDOW} samples", '
        f'`{long}` the last {window} samples; held-out: predict-only on the held-out run '
        f'after the stream. The effort varies little within {PAPER_WINDOW} samples '
        f'({PAPER_WINDOW / 1000:g} s), so the NMSE over them is a noisy figure; `{long}` '
        'is the steadier one. LS: least squares fitted on the stream before the windows, '
        'with the same estimated q\'\'. hold: no model, each effort predicted as the '
        'previous sample\'s; an online error is only worth something below it.\n',
        online_markdown(summaries, short=short, long=long, test=HELD_OUT),
        'Held-out NMSE per joint:\n',
        joint_markdown(summaries, table='online', data=HELD_OUT),
        ranking_text(summaries, 'online', [(short, 'mse_mean', f'{short} MSE'),
                                           (long, 'nmse_mean', f'{long} NMSE'),
                                           (HELD_OUT, 'nmse_mean', 'held-out NMSE')],
                     labels),
        f'**Paper\'s numbers.** {PAPER_NOTE}\n\n',
        '## Conditions\n', _conditions_markdown(c)]
    return '\n'.join(parts)


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
                window: int) -> dict[str, Any]:
    return {
        'options': {k: (str(v) if isinstance(v, Path) else v) for k, v in asdict(s).items()},
        'quick': bool(s.quick),
        'preset': s.preset, 'train_seed': s.train_seed, 'test_seed': s.test_seed,
        'seeds': seeds, 'methods': [method_spec(m).label for m in methods],
        'train_seconds': s.train_seconds, 'test_seconds': s.test_seconds,
        'online_seconds': s.online_seconds, 'search_seconds': s.search_seconds,
        'iterations': s.iterations, 'samples': s.samples, 'goal': s.goal,
        'goal_units': 'training MSE of outputs scaled to [-1, 1] by the training min-max',
        'online_window': window, 'paper_window': PAPER_WINDOW,
        'offline_acceleration': s.acceleration, 'online_acceleration': 'estimated',
        'differentiator': f'centred, window {DIFFERENTIATOR_WINDOW}, degree 2 (identifier '
                          'default, zero-phase)',
        'offline_scaling': 'min-max of the LM training samples',
        'online_scaling': 'robot joint limits (methods.limit_scaling)',
        'network': '12-40-4', 'sample_rate_hz': 1000.0,
        'simulation': 'SimConfig() defaults: no noise, no disturbance, no model mismatch',
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

