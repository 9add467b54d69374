"""Learning curves: frozen models scored on held-out motion; the RLS reference."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics import LeastSquaresIdentifier, ScaraParams
from scara_ident_ros.dynamics.recursive_least_squares import RecursiveLeastSquares
from scara_ident_ros.paper.datasets import simulate_record
from scara_ident_ros.paper.figures import learning_curves_figure, plot_learning_curves
from scara_ident_ros.paper.learning_curves import (Curve, curves_markdown, held_out_set,
                                                   network_curve, physical_model_of,
                                                   regressor_curves, robot_by_name, run_curves)
from scara_ident_ros.sim import SimConfig, SimRecord

PARAMS = ScaraParams()


@pytest.fixture(scope='module')
def stream() -> SimRecord:
    return simulate_record(PARAMS, seconds=6.0, seed=4, preset='sequence')


def test_rls_equals_batch_least_squares(stream: SimRecord) -> None:
    rls = RecursiveLeastSquares(p0=1e9)
    for start in range(0, 3000, 137):  # blocks of any size: the same recursion
        block = slice(start, min(start + 137, 3000))
        rls.update(stream.q[block], stream.qd[block], stream.qdd[block], stream.effort[block])
    batch = LeastSquaresIdentifier().fit(stream.q[:3000], stream.qd[:3000],
                                         stream.qdd[:3000], stream.effort[:3000])
    assert rls.count == 3000
    np.testing.assert_allclose(rls.theta, batch.theta_, rtol=1e-5, atol=1e-6)
    # with the true q'' the model is exact: so are the predictions of the remaining samples
    np.testing.assert_allclose(rls.predict(stream.q[3000:], stream.qd[3000:],
                                           stream.qdd[3000:]), stream.effort[3000:],
                               atol=1e-5)


def test_curves_score_frozen_models_on_motion_never_streamed(stream: SimRecord,
                                                             tmp_path: Path) -> None:
    held_out = held_out_set(PARAMS, excitation_s=1.0, sequence_s=3.0)
    assert len(held_out) == 5 * 1000 + 3000 and held_out.acceleration == 'estimated'
    # no held-out state is a stream state (other excitations)
    assert not np.isin(held_out.X[:, 0], stream.q[:, 0]).any()
    ls, rls = regressor_curves(stream, held_out, checkpoints=(2.0, 5.0))
    bp = network_curve(stream, held_out, PARAMS, method='ffs', trainer='bp',
                       checkpoints=(2.0, 5.0))
    assert ls.nmse.shape == rls.nmse.shape == bp.nmse.shape == (2, 4)
    # the model-based references identify from seconds of data; their floor is the q''
    # estimate (Coulomb friction's jumps), far below the networks'
    assert np.all(ls.nmse[-1] < 1e-3) and np.all(rls.nmse[-1] < 1e-3)
    assert np.all(bp.nmse[-1] > ls.nmse[-1])
    assert bp.cpu_s > 0
    table = curves_markdown([ls, rls, bp], noise_floor=np.full(4, 1e-5))
    assert '| FFS bp |' in table and '| LS |' in table and 'Noise floor' in table
    path = plot_learning_curves(tmp_path / 'curves.png', [ls, rls, bp])
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    fig = learning_curves_figure([ls, rls, bp])  # what that PNG shows: each worst joint
    lines = fig.axes[0].get_lines()
    assert [line.get_label() for line in lines] == ['LS', 'RLS', 'FFS bp']
    for line, curve in zip(lines, (ls, rls, bp)):
        np.testing.assert_array_equal(line.get_xdata(), curve.seconds)
        np.testing.assert_array_equal(line.get_ydata(), curve.nmse.max(axis=1))
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_curves_run_for_a_urdf_arm() -> None:
    """``--robot ur5`` in a CI-sized setting: the arm's physical model gives LS and RLS, the
    network learns its 6 joints through the identifier's pipeline."""
    curves = run_curves('ur5', seeds=[0], methods=['ffs'], trainers=['lm'], seconds=2.0,
                        workers=1, held_out_s=(0.5, 1.0))
    assert [curve.label for curve in curves] == ['LS', 'RLS', 'FFS lm']
    for curve in curves:
        assert curve.nmse.shape == (1, 6) and np.all(np.isfinite(curve.nmse))
    ls, rls, network = curves
    # the physical model identifies the arm from 2 s (the Stribeck bump it lacks and the
    # q'' estimate are its floor); RLS on the same rows is the same fit
    assert np.all(ls.nmse < 0.05), ls.nmse
    np.testing.assert_allclose(rls.nmse, ls.nmse, rtol=0.05)
    assert network.cpu_s > 0 and network.nmse.max() > ls.nmse.max()


def test_hybrid_curve_on_a_urdf_arm() -> None:
    """``--methods hybrid --stribeck`` at a small size: the hybrid starts as the physical
    model (RLS) and its network, fitted to the residuals of the current θ and checked on
    samples it does not learn and bounded by their range, does not spoil it (with the
    a-priori residuals of each sample it did: docs/results.md, other arms)."""
    done: list[list[Curve]] = []
    curves = run_curves('ur5', seeds=[0], methods=['hybrid'], trainers=['lm'], seconds=3.0,
                        workers=1, held_out_s=(0.5, 1.0), stribeck=True, finished=done.append)
    assert [curve.label for curve in curves] == ['LS', 'RLS', 'hybrid']
    assert [[c.label for c in job] for job in done] == [['LS', 'RLS'], ['hybrid']]
    rls, hybrid = curves[1], curves[2]
    assert hybrid.nmse.shape == (1, 6) and hybrid.cpu_s > 0
    assert hybrid.nmse.max() < 3 * rls.nmse.max(), (hybrid.nmse, rls.nmse)
    assert hybrid.nmse.max() < 1e-2


def test_background_hybrid_curve_on_a_urdf_arm() -> None:
    """The node's default path (``lm`` in a learner process, the stream at its own pace)
    learns the hybrid as the synchronous one does: the same order on held-out motion."""
    params = robot_by_name('ur5')
    record = simulate_record(params, seconds=3.0, seed=0, preset='sequence',
                             config=SimConfig(seed=0, n_joints=6))
    held_out = held_out_set(params, excitation_s=0.5, sequence_s=1.0)
    sync, background = (
        network_curve(record, held_out, params, method='hybrid', trainer='lm',
                      checkpoints=(3.0,), physical=physical_model_of('ur5', stribeck=True),
                      background=beside)
        for beside in (False, True))
    assert (sync.label, background.label) == ('hybrid', 'hybrid (background)')
    assert background.nmse.shape == (1, 6) and np.all(np.isfinite(background.nmse))
    ours, theirs = background.nmse.max(), sync.nmse.max()
    assert theirs / 10 <= ours <= theirs * 10, (ours, theirs)
