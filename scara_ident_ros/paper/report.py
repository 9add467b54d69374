"""The paper's Tables 2–3 and Figures 6–15 from recorded runs: ``DIR/report.md`` and files.

Input: one or more bags. The first is the run analysed; it needs joint states (with effort)
and, for the online part, what ``scara-ident run`` records besides: per method
``/<m>/identified_torque`` (a-priori predictions stamped like their input) and
``/<m>/identification_mse``. Further bags are held-out runs (other excitations).

Offline (Table 2 analog, Figures 6–13 offline and 14)
    :func:`~scara_ident_ros.paper.retraining.retrain`: each method retrained with
    Levenberg–Marquardt from several seeds on samples of the run's training blocks, evaluated
    on its validation blocks (the split of ``scara-ident train``) and on the held-out runs.
Online (Table 3 analog, Figures 6–13 online and 15)
    Each identifier's published predictions paired by stamp with ``/joint_states``
    (:mod:`~scara_ident_ros.paper.online_results`).

Files written to ``out_dir``: ``report.md``, ``table2_offline.csv`` and
``table3_online.csv`` (every row, every seed), ``fig_torque_online_<m>.png``,
``fig_torque_offline_<m>.png``, ``fig14_training_mse.png``, ``fig15_online_error.png``.
The default time budget (:data:`DEFAULT_TIME_BUDGET_S`) stops starting rounds of seeds so
that ``make demo`` stays within its 3 minutes (timings: docs/results.md).
"""
from __future__ import annotations

import math
import os
import platform
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.table2 import DEFAULT_GOAL, OfflineFit
from scara_ident_ros.paper.table3 import DEFAULT_WINDOW, stream_data_names
from scara_ident_ros.paper.reference import is_scara
from scara_ident_ros.paper.rows import ResultRow, summarise
from scara_ident_ros.paper.tables import (PAPER_ITERATIONS, PAPER_NOTE, PAPER_SAMPLES,
                                          PAPER_TABLE2, PAPER_TABLE3, format_value, joint_markdown,
                                          offline_markdown, online_markdown, ranking_text,
                                          write_csv)
from scara_ident_ros.identification import DIFFERENTIATOR_WINDOW, PAPER_WINDOW
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.mse_layout import METRICS, decode_mse
from scara_ident_ros.nn import DEFAULT_CONSTANTS
from scara_ident_ros.blas_threads import BLAS_THREADS
from scara_ident_ros.paper.software_versions import software_versions
from scara_ident_ros.paper.figures import plot_online_error, plot_torque, plot_training_mse
from scara_ident_ros.paper.online_results import (STREAM_ALL, OnlinePredictions, prediction_rows,
                                                  read_identifier_mse, read_online_predictions,
                                                  rolling_errors, torque_topic)
from scara_ident_ros.identification.recording import Recording, load_recording, skipped_text
from scara_ident_ros.identification.split import (VALIDATION_BLOCK_S, VALIDATION_FRACTION,
                                                   block_split)
from scara_ident_ros.paper.retraining import Retraining, retrain

__all__ = ['DEFAULT_SAMPLES', 'DEFAULT_SEEDS', 'DEFAULT_TIME_BUDGET_S', 'FIGURE_NMSE_WINDOW',
           'make_report']

#: Seeds of the initial weights per method (0 .. 4).
DEFAULT_SEEDS = 5
#: Training samples drawn at random from the run for Levenberg–Marquardt.
DEFAULT_SAMPLES = 500
#: Offline training time (s) after which ``make_report`` starts no new round of seeds.
DEFAULT_TIME_BUDGET_S = 40.0
#: Window (samples) of the normalised error curve of Figure 15: the identifier's default.
FIGURE_NMSE_WINDOW = 1000

Progress = Callable[[str], None]


def _stderr(line: str) -> None:
    print(f'scara-ident tables: {line}', file=sys.stderr, flush=True)


@dataclass
class _Timer:
    """Wall time per phase, s."""

    phases: dict[str, float] = field(default_factory=dict)
    _start: float = field(default_factory=time.perf_counter)

    def lap(self, phase: str) -> None:
        now = time.perf_counter()
        self.phases[phase] = self.phases.get(phase, 0.0) + now - self._start
        self._start = now


@dataclass
class _Online:
    predictions: dict[str, OnlinePredictions]
    rows: list[ResultRow]
    published: dict[str, np.ndarray]  # method -> data of its last identification_mse
    missing: list[str]


@dataclass(frozen=True)
class _Settings:
    methods: list[str]
    seeds: list[int]
    iterations: int
    samples: int
    validation_fraction: float
    validation_block_s: float
    goal: float
    topic: str | None
    time_budget_s: float | None


def make_report(bags: Sequence[Path], out_dir: Path, *,
                methods: Sequence[str] = tuple(METHODS),
                seeds: int | Iterable[int] = DEFAULT_SEEDS,
                iterations: int = PAPER_ITERATIONS, samples: int = DEFAULT_SAMPLES,
                validation_fraction: float = VALIDATION_FRACTION,
                validation_block_s: float = VALIDATION_BLOCK_S, goal: float = DEFAULT_GOAL,
                topic: str | None = None,
                time_budget_s: float | None = DEFAULT_TIME_BUDGET_S,
                progress: Progress | None = _stderr, reference: bool | None = None) -> Path:
    """Write the tables, figures and ``report.md`` of recorded runs into ``out_dir``.

    Parameters
    ----------
    bags : sequence of Path
        The run to analyse, then any held-out runs.
    out_dir : Path
        Output directory (created; files in it are overwritten).
    seeds : int or iterable of int
        A count (seeds 0 .. count−1) or the seeds of the initial weights.
    samples : int
        Training samples drawn from the run's training part (0: all).
    validation_fraction, validation_block_s : float
        Fraction in [0, 1) of the run's time blocks of ``validation_block_s`` seconds kept
        out of training (:func:`~scara_ident_ros.identification.split.block_split`).
    goal : float
        Training MSE goal (outputs scaled to [-1, 1]) for "iterations to the goal".
    time_budget_s : float or None
        See :func:`~scara_ident_ros.paper.retraining.retrain`; None: all seeds.
    progress : callable, optional
        Called with one line per step; default print to stderr; None: silent.
    reference : bool, optional
        Add the SCARA's least-squares reference (LS) to Table 2; by default when
        :func:`~scara_ident_ros.paper.reference.is_scara` says the joints are the SCARA's.

    Returns
    -------
    Path
        ``out_dir / 'report.md'``.

    Raises
    ------
    BagError, RecordingError
        If a bag cannot be read or has too few usable joint-state samples.
    SplitError
        If the run fills too few blocks for the validation split.
    ValueError
        On invalid arguments.
    """
    say = progress or (lambda line: None)
    bags = [Path(bag) for bag in bags]
    if not bags:
        raise ValueError('need at least one bag')
    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    settings = _Settings([method_spec(m).name for m in methods], seed_list, int(iterations),
                         int(samples), float(validation_fraction),
                         float(validation_block_s), float(goal), topic,
                         time_budget_s)
    if not settings.methods or not seed_list or iterations < 1 or samples < 0:
        raise ValueError('need a method, a seed, iterations >= 1 and samples >= 0')
    out_dir = Path(out_dir)
    timer = _Timer()

    run = load_recording(bags[0], topic=topic)
    names = run.samples.names
    held_out = [load_recording(bag, topic=topic, joints=names) for bag in bags[1:]]
    train_part, validation = block_split(run.samples.data, validation_fraction,
                                         block_s=validation_block_s)
    timer.lap('reading bags')
    say(f'{bags[0]}: {len(run.samples.data)} samples of {len(names)} joints over '
        f'{run.samples.data.seconds:.1f} s')

    if reference is None:
        reference = is_scara(names, run.samples.data.X)
    offline = retrain(train_part, validation, [r.samples.data for r in held_out],
                      methods=settings.methods, seeds=seed_list, iterations=iterations,
                      n_samples=samples, goal=goal, time_budget_s=time_budget_s,
                      progress=say, reference=reference)
    timer.lap('offline training')
    out_dir.mkdir(parents=True, exist_ok=True)  # not before the inputs are known good
    online = _online(run, settings.methods, say)
    timer.lap('online results')
    figures = _figures(out_dir, run, offline, online, settings)
    timer.lap('figures')

    write_csv(out_dir / 'table2_offline.csv', offline.rows, joint_names=names)
    write_csv(out_dir / 'table3_online.csv', online.rows, joint_names=names)
    timer.lap('tables')
    report = out_dir / 'report.md'
    report.write_text(_markdown(bags, run, held_out, offline, online, figures, settings,
                                timer), encoding='utf-8')
    say(f'report written to {report} in {sum(timer.phases.values()):.1f} s')
    return report


def _online(run: Recording, methods: list[str], say: Progress) -> _Online:
    result = _Online({}, [], {}, [])
    for m in methods:
        pred = read_online_predictions(run.path, m, run.series)
        if pred is None or pred.stamp_ns.shape[0] == 0:
            result.missing.append(m)
            continue
        result.predictions[m] = pred
        rows = prediction_rows(pred)
        result.rows.extend(rows)
        mse = read_identifier_mse(run.path, m)
        if mse is not None:
            result.published[m] = mse[1][-1]
        say(f'online {rows[0].method}: {pred.stamp_ns.shape[0]} predictions paired, '
            f'{rows[0].data} MSE {format_value(rows[0].mse_mean)}')
    return result


# --------------------------------------------------------------------------------- figures
def _median_fit(fits: list[OfflineFit], data: Dataset) -> OfflineFit:
    """The fit of median NMSE on ``data`` (the lower one of the middle two)."""
    scores = [effort_errors(data.Y, f.network.predict(data.X)).nmse_total for f in fits]
    order = sorted(range(len(fits)),
                   key=lambda i: scores[i] if math.isfinite(scores[i]) else math.inf)
    return fits[order[(len(order) - 1) // 2]]


def _figures(out_dir: Path, run: Recording, offline: Retraining, online: _Online,
             settings: _Settings) -> dict[str, str]:
    names = run.samples.names
    figures: dict[str, str] = {}
    shown = offline.evaluations[offline.test]
    for m in settings.methods:
        label = method_spec(m).label
        pred = online.predictions.get(m)
        if pred is not None:
            path = plot_torque(out_dir / f'fig_torque_online_{m}.png', pred.time_s,
                               pred.measured, pred.predicted, names,
                               title=f'{label}: measured and identified (online, a priori) '
                                     f'effort per joint, {run.path.name}')
            figures[f'online {m}'] = path.name
        if offline.fits.get(m):
            fit = _median_fit(offline.fits[m], shown)
            path = plot_torque(out_dir / f'fig_torque_offline_{m}.png',
                               (shown.stamp_ns - shown.stamp_ns[0]) * 1e-9, shown.Y,
                               fit.network.predict(shown.X), names,
                               title=f'{label}: measured and identified effort on the '
                                     f'{offline.test} data (offline LM, seed {fit.seed})')
            figures[f'offline {m}'] = path.name
    curves = {method_spec(m).label: [f.history.mse for f in offline.fits.get(m, [])]
              for m in settings.methods}
    figures['fig14'] = plot_training_mse(
        out_dir / 'fig14_training_mse.png', curves, goal=settings.goal,
        title='Fig. 14 analog: offline Levenberg–Marquardt training MSE').name
    if online.predictions:
        online_curves = {}
        for m, pred in online.predictions.items():
            mse, _ = rolling_errors(pred.measured, pred.predicted, PAPER_WINDOW)
            _, nmse = rolling_errors(pred.measured, pred.predicted, FIGURE_NMSE_WINDOW)
            online_curves[method_spec(m).label] = (pred.time_s, mse, nmse)
        figures['fig15'] = plot_online_error(
            out_dir / 'fig15_online_error.png', online_curves,
            title='Fig. 15 analog: online a-priori error of the identifiers during the run',
            mse_window=PAPER_WINDOW, nmse_window=FIGURE_NMSE_WINDOW).name
    return figures


# -------------------------------------------------------------------------------- markdown
def _markdown(bags: list[Path], run: Recording, held_out: list[Recording],
              offline: Retraining, online: _Online, figures: dict[str, str],
              settings: _Settings, timer: _Timer) -> str:
    names = run.samples.names
    summaries = summarise(offline.rows + online.rows)
    labels = [method_spec(m).label for m in settings.methods]
    short, long = stream_data_names(DEFAULT_WINDOW, PAPER_WINDOW)
    parts: list[str] = [
        '# Inverse-dynamics identification: the paper\'s tables and figures from recorded '
        'runs',
        f'Run analysed: `{run.path}` (`{run.topic}`, {len(names)} joints: '
        f'{", ".join(names)})' + (f'; held-out runs: '
                                  f'{", ".join(f"`{r.path}`" for r in held_out)}.'
                                  if held_out else '.'),
        f'_{PAPER_NOTE}_',
        _paper_table(),
        '## Table 2 analog: offline training (Levenberg–Marquardt)',
        f'Each network trained from {len(offline.seeds)} seeds '
        f'({", ".join(map(str, offline.seeds))}) for {settings.iterations} iterations on '
        f'{len(offline.evaluations["train"])} samples of the run\'s training blocks. '
        'Cells: median [min–max] over seeds. MSE: mean over the joints of each joint\'s MSE'
        ' in physical units ((N·m)² and N² mixed, like the paper); NMSE: mean '
        'over the joints of MSE / variance of the joint\'s effort. "Goal reached": runs '
        f'whose training MSE (outputs scaled to [-1, 1]) reached {settings.goal:g}, and '
        f'the iterations it took. `{offline.test}` = '
        + ('the first held-out run.' if held_out else
           'the run\'s validation blocks, never trained on.')
        + (' LS: the model-based least-squares reference (the SCARA\'s 14 base '
           'parameters), for comparison.' if any(r.method == 'LS' for r in offline.rows)
           else ''),
        offline_markdown(summaries, train='train', test=offline.test).rstrip(),
        'Per-joint NMSE, median [min–max] over seeds:']
    for data, dataset in offline.evaluations.items():
        parts.append(f'`{data}` ({len(dataset)} samples):')
        parts.append(joint_markdown(summaries, table='offline', data=data,
                                    joint_names=names).rstrip())
    parts.append(ranking_text(summaries, 'offline', [(data, 'nmse_mean', f'`{data}` NMSE')
                                                     for data in ('train', offline.test)],
                              labels))

    parts.append('## Table 3 analog: online identification during the run')
    if online.predictions:
        parts += [
            'From what each identifier published during the run: its a-priori prediction of '
            'every sample (`/<method>/identified_torque`, made before learning from the '
            'sample) paired by stamp with the measured effort on `/joint_states`. '
            f'`{short}`: the last {PAPER_WINDOW} samples (the paper\'s "error over 100 '
            f'samples"); `{long}`: the last {DEFAULT_WINDOW}; `{STREAM_ALL}`: the whole run. '
            'One run per method: single values, no spread.',
            online_markdown(summaries, short=short, long=long, test=STREAM_ALL).rstrip(),
            _published_table(online, names),
            f'Per-joint NMSE over the last {DEFAULT_WINDOW} samples:',
            joint_markdown(summaries, table='online', data=long, joint_names=names).rstrip(),
            ranking_text(summaries, 'online', [(data, 'nmse_mean', f'`{data}` NMSE')
                                               for data in (short, long)], labels)]
    if online.missing:
        parts.append('No online predictions in the bag for '
                     + ', '.join(f'{method_spec(m).label} (`{torque_topic(m)}`)'
                                 for m in online.missing) + '.')

    parts.append('## Figures')
    for m in settings.methods:
        label = method_spec(m).label
        for kind, text in (('online', 'during the run (online, a priori)'),
                           ('offline', f'offline LM model on the `{offline.test}` data')):
            if f'{kind} {m}' in figures:
                parts.append(f'**Figs 6–13 analog, {label}, {text}:** measured and '
                             f'identified effort per joint.\n\n'
                             f'![{label} {kind}]({figures[f"{kind} {m}"]})')
    parts.append('**Fig. 14 analog:** training MSE against iteration (median bold, each seed '
                 f'thin).\n\n![Fig. 14]({figures["fig14"]})')
    if 'fig15' in figures:
        parts.append(f'**Fig. 15 analog:** online error against time: MSE over the last '
                     f'{PAPER_WINDOW} samples (mean over joints) and NMSE over the last '
                     f'{FIGURE_NMSE_WINDOW}.\n\n![Fig. 15]({figures["fig15"]})')

    parts += ['## Conditions (to reproduce)',
              _reproduction_text(bags, run, held_out, offline, settings),
              '## Time', _time_text(timer, offline, settings),
              'Files: `table2_offline.csv`, `table3_online.csv` (every row, every seed, '
              'per-joint columns) and the PNG figures above.']
    return '\n\n'.join(part for part in parts if part) + '\n'


def _paper_table() -> str:
    """The paper's Tables 2 and 3 as printed."""
    lines = ["The paper's numbers, as printed:", '',
             f'| method | Table 2: MSE after {PAPER_ITERATIONS} iterations (offline) '
             f'| Table 3: error over {PAPER_SAMPLES} samples (online) |', '|---|---|---|']
    for label, mse in PAPER_TABLE2.items():
        lines.append(f'| {label} | {mse:.4e} | {PAPER_TABLE3[label]:.4e} |')
    return '\n'.join(lines)


def _published_table(online: _Online, names: tuple[str, ...]) -> str:
    n = len(names)
    lines = ['What the identifiers published last on `/<method>/identification_mse` (over '
             'their own window, the identifier\'s `mse_window`), and how many predictions '
             'were paired with a measurement:', '',
             '| method | published MSE | published NMSE | published validation NMSE '
             '| predictions | paired | unmatched |',
             '|---|---|---|---|---|---|---|']
    for m, pred in online.predictions.items():
        data = online.published.get(m)
        try:
            rows = decode_mse(data, n) if data is not None else {}
        except ValueError:  # not the layout of these joints
            rows = {}
        mse, nmse, validation = (format_value(float(rows[metric][-1])) if metric in rows
                                 else '—' for metric in METRICS)
        lines.append(f'| {method_spec(m).label} | {mse} | {nmse} | {validation} | '
                     f'{pred.n_published} | {pred.stamp_ns.shape[0]} | {pred.n_unmatched} |')
    return '\n'.join(lines)


def _reproduction_text(bags: list[Path], run: Recording, held_out: list[Recording],
                       offline: Retraining, s: _Settings) -> str:
    lines = []
    for recording in [run, *held_out]:
        data = recording.samples
        lines.append(f'- `{recording.path}`: `{recording.topic}`, '
                     f'{recording.series.stamp_ns.shape[0]} messages, {len(data.data)} '
                     f'usable samples over {data.data.seconds:.1f} s (skipped: '
                     f'{skipped_text(data)}).')
    lines.append('- Network inputs as the online identifier makes them (its `InputStage`): '
                 '[q, q\', q\'\'] with q\'\' from q\' by a centred quadratic fit over '
                 f'{DIFFERENTIATOR_WINDOW} samples (zero-phase, '
                 f'`CentredDifferentiator({DIFFERENTIATOR_WINDOW}, 2)`), invalid samples '
                 'dropped; outputs: the measured efforts.')
    subsample = (f'{len(offline.evaluations["train"])} of them drawn at random '
                 '(`Dataset.subsample(seed=0)`, the same for every method and seed)'
                 if s.samples else 'all of them')
    lines.append(f'- Offline: the run cut into blocks of {s.validation_block_s:g} s, '
                 f'{100 * s.validation_fraction:.0f} % of them validating (one drawn from '
                 'each stretch of 1/fraction blocks, seed 0, as `scara-ident train` does); '
                 f'the other blocks\' {offline.n_train_part} samples train, {subsample}; '
                 'min–max scaling to [-1, 1] from the training samples; 3n-40-n networks; seeds '
                 f'{", ".join(map(str, offline.seeds))}; Levenberg–Marquardt (μ from 1e-3, '
                 f'×10 on failure, ÷10 on success, as MATLAB\'s trainlm), {s.iterations} '
                 f'iterations, no early stopping; the goal {s.goal:g} is only counted.'
                 + (f' Seeds {", ".join(map(str, offline.seeds_skipped))} were asked for '
                    f'but left out: the time budget of {s.time_budget_s:g} s for offline '
                    'training was reached.' if offline.seeds_skipped else ''))
    train_x = offline.evaluations['train'].X
    outside = [f'`{name}` {100 * _outside_fraction(train_x, data.X):.1f} %'
               for name, data in offline.evaluations.items() if name != 'train']
    if outside:
        lines.append('- Samples with an input outside the range of the training samples '
                     '(where the networks extrapolate): ' + ', '.join(outside) + '.')
    for m in s.methods:
        spec = METHODS[m]
        k, a, b = DEFAULT_CONSTANTS[spec.activation]
        lines.append(f'- {spec.label}: {spec.activation} hidden units (k={k:g}, a={a:g}, '
                     f'b={b:g}), initial weight scale {spec.weight_scale:g}; online defaults '
                     f'of the identifier: learning rate {spec.learning_rate:g}, momentum '
                     f'{spec.momentum:g} (unless the run set others).')
    command = ['scara-ident tables', *map(str, bags), '--out DIR',
               f'--methods {" ".join(s.methods)}', f'--seeds {len(offline.seeds)}',
               f'--iterations {s.iterations}', f'--samples {s.samples}',
               f'--validation-fraction {s.validation_fraction:g}',
               f'--validation-block {s.validation_block_s:g}']
    if s.topic:
        command.append(f'--topic {s.topic}')
    contiguous = offline.seeds == list(range(len(offline.seeds)))
    lines.append(f'- Command: `{" ".join(command)}`'
                 + ('' if contiguous else f' (the seeds here were {offline.seeds})'))
    lines.append('- Software: ' + ', '.join(f'{k} {v}' for k, v in software_versions().items())
                 + f', {platform.system()} {platform.machine()}, BLAS threads while training: '
                 f'{BLAS_THREADS}.')
    return '\n'.join(lines)


def _outside_fraction(train_x: np.ndarray, x: np.ndarray) -> float:
    """Fraction of the rows of x (N, k) with an input outside train_x's column ranges."""
    if x.shape[0] == 0 or train_x.shape[0] == 0:
        return 0.0
    low, high = train_x.min(axis=0), train_x.max(axis=0)
    return float(np.mean(np.any((x < low) | (x > high), axis=1)))


def _time_text(timer: _Timer, offline: Retraining, s: _Settings) -> str:
    total = sum(timer.phases.values())
    fits = [f for runs in offline.fits.values() for f in runs]
    per_iteration = (1e3 * sum(f.seconds for f in fits)
                     / max(1, sum(f.history.iterations for f in fits)))
    return (', '.join(f'{phase} {seconds:.1f} s' for phase, seconds in timer.phases.items())
            + f'; total {total:.1f} s wall time with {_cpus()} CPUs available. One LM '
            f'iteration took {per_iteration:.1f} ms on average ({len(fits)} trainings of '
            f'{s.iterations} iterations on {len(offline.evaluations["train"])} samples).')


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1
