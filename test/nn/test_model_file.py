"""Saving and loading networks: exact round trips, and clear refusals of bad files."""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.nn import FORMAT_VERSION, FeedForwardNet, ModelFormatError
from scara_ident_ros.nn.model_file import NETWORK_PREFIX, read_model, read_model_file, write_model


def trained_net(name: str = 'mslog') -> FeedForwardNet:
    rng = np.random.default_rng(0)
    net = FeedForwardNet(12, 10, 4, name, seed=5, k=2.0, a=4.0, b=3.0, learning_rate=0.02,
                         momentum=0.7)
    net.set_scaling(-np.arange(1, 13), np.arange(1, 13), [-50, -40, -30, -5], [50, 40, 30, 5])
    net.partial_fit(rng.uniform(-1, 1, (20, 12)), rng.uniform(-5, 5, (20, 4)))
    net.metadata['joint_names'] = np.array(['joint1', 'joint2', 'joint3', 'joint4'])
    net.metadata['samples'] = np.array(20)
    return net


def test_round_trip_is_exact(tmp_path: Path, name: str) -> None:
    net = trained_net(name)
    path = tmp_path / 'ffmw.npz'
    net.save(path)
    loaded = FeedForwardNet.load(path)
    assert repr(loaded) == repr(net)
    assert (loaded.n_inputs, loaded.n_hidden, loaded.n_outputs) == (12, 10, 4)
    assert loaded.activation == name and loaded.constants == net.constants
    assert (loaded.learning_rate, loaded.momentum) == (0.02, 0.7)
    assert loaded.weight_scale == net.weight_scale and loaded.seed == net.seed
    np.testing.assert_array_equal(loaded.get_theta(), net.get_theta())
    np.testing.assert_array_equal(loaded.x_scaling.lo, net.x_scaling.lo)
    np.testing.assert_array_equal(loaded.y_scaling.hi, net.y_scaling.hi)
    assert loaded.metadata['joint_names'].tolist() == ['joint1', 'joint2', 'joint3', 'joint4']
    assert int(loaded.metadata['samples']) == 20
    x, y = np.random.default_rng(1).uniform(-1, 1, (30, 12)), np.ones((30, 4))
    np.testing.assert_array_equal(loaded.predict(x), net.predict(x))
    # Online learning goes on exactly as it would have (momentum state included).
    np.testing.assert_array_equal(loaded.partial_fit(x, y), net.partial_fit(x, y))
    np.testing.assert_array_equal(loaded.get_theta(), net.get_theta())


def test_unscaled_network_stays_unscaled(tmp_path: Path) -> None:
    FeedForwardNet(3, 4, 2).save(tmp_path / 'raw.npz')
    assert not FeedForwardNet.load(tmp_path / 'raw.npz').scaling_set


def test_path_is_used_as_given_and_no_temporaries_remain(tmp_path: Path) -> None:
    net = trained_net()
    net.save(tmp_path / 'model')
    net.save(str(tmp_path / 'model'))  # overwrite
    assert sorted(p.name for p in tmp_path.iterdir()) == ['model']
    FeedForwardNet.load(str(tmp_path / 'model'))


def test_file_holds_no_pickle(tmp_path: Path) -> None:
    trained_net().save(tmp_path / 'm.npz')
    with np.load(tmp_path / 'm.npz', allow_pickle=False) as archive:
        for key in archive.files:
            assert archive[key].dtype != object
        assert int(archive['format_version']) == FORMAT_VERSION


def test_metadata_that_needs_pickle_is_refused(tmp_path: Path) -> None:
    net = FeedForwardNet(3, 4, 2)
    net.metadata['bad'] = np.array([{'a': 1}], dtype=object)
    with pytest.raises(ValueError, match='no pickle'):
        net.save(tmp_path / 'm.npz')
    assert list(tmp_path.iterdir()) == []


def rewrite(source: Path, target: Path, **changes: object) -> None:
    with np.load(source) as archive:
        entries = {key: archive[key] for key in archive.files}
    for key, value in changes.items():
        if value is None:
            del entries[key]
        else:
            entries[key] = np.asarray(value)
    with open(target, 'wb') as stream:
        np.savez(stream, **entries)


@pytest.fixture()
def good_file(tmp_path: Path) -> Path:
    path = tmp_path / 'good.npz'
    trained_net().save(path)
    return path


@pytest.mark.parametrize(('changes', 'message'), [
    ({'format': 'something.else'}, 'not a scara_ident_ros network file'),
    ({'format': None}, 'not a scara_ident_ros network file'),
    ({'format_version': 2}, 'format version 2, this code reads version 1'),
    ({'format_version': None}, 'format_version'),
    ({'params': None}, "missing entries \\['params'\\]"),
    ({'params': np.zeros(5)}, 'params must be float64 of shape'),
    ({'sizes': np.array([12, 10])}, 'sizes'),
    ({'activation': 'relu'}, 'activation'),
    ({'constants': np.array([2.5, 0.0, 5.0])}, 'constant a is 0'),
    ({'x_min': np.full(12, np.nan)}, 'non-finite'),
    ({'y_max': -np.full(4, 100.0)}, 'max < min'),
    ({'extra': np.zeros(3)}, 'unknown entries'),
])
def test_bad_entries_are_refused(good_file: Path, changes: dict[str, object],
                                 message: str) -> None:
    bad = good_file.with_name('bad.npz')
    rewrite(good_file, bad, **changes)
    with pytest.raises(ModelFormatError, match=message) as caught:
        FeedForwardNet.load(bad)
    assert str(bad) in str(caught.value)
    assert isinstance(caught.value, ValueError)


def test_other_files_are_refused(tmp_path: Path, good_file: Path) -> None:
    text = tmp_path / 'notes.txt'
    text.write_text('not a network\n')
    array = tmp_path / 'array.npy'
    np.save(array, np.zeros(3))
    truncated = tmp_path / 'truncated.npz'
    truncated.write_bytes(good_file.read_bytes()[:300])
    pickled = tmp_path / 'pickled.npz'
    np.savez(pickled, format=np.array(['x', None], dtype=object))
    empty = tmp_path / 'empty.npz'
    empty.write_bytes(b'')
    expected = {text: r'notes\.txt: not a \.npz network file \(not a zip/\.npz archive\)$',
                array: r'array\.npy: a single \.npy array, not a network file$',
                truncated: r'truncated\.npz: not a \.npz network file \(a truncated or '
                           r'damaged zip archive\)$',
                pickled: r"pickled\.npz: not a network file of ours: entry 'format' is an "
                         r'object array',
                empty: r'empty\.npz: not a \.npz network file \(an empty file\)$',
                tmp_path: r': is a directory, not a network file$'}
    for path, message in expected.items():
        with pytest.raises(ModelFormatError, match=message) as caught:
            FeedForwardNet.load(path)
        assert str(caught.value).startswith(f'{path}: ')
        assert '\n' not in str(caught.value)
        if path is not pickled:  # numpy's advice on unpickling is not for these
            assert 'pickle' not in str(caught.value)


def test_corrupt_member_is_refused(tmp_path: Path, good_file: Path) -> None:
    corrupt = tmp_path / 'corrupt.npz'
    data = bytearray(good_file.read_bytes())
    with zipfile.ZipFile(good_file) as archive:
        info = archive.getinfo('params.npy')
    middle = info.header_offset + 30 + len(info.filename) + info.file_size // 2
    data[middle] ^= 0xFF  # flip a byte inside the weights: the CRC no longer matches
    corrupt.write_bytes(bytes(data))
    with pytest.raises(ModelFormatError, match='corrupt'):
        FeedForwardNet.load(corrupt)


def test_missing_file_is_file_not_found(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match='nothing.npz'):
        read_model(tmp_path / 'nothing.npz')


def test_kinds(tmp_path: Path, good_file: Path) -> None:
    """A network file has no kind entry (as before kinds); other kinds carry theirs."""
    with np.load(good_file) as archive:
        assert 'kind' not in archive.files
    assert read_model_file(good_file).kind == 'network'
    unknown = tmp_path / 'unknown.npz'
    rewrite(good_file, unknown, kind='lookup_table')
    with pytest.raises(ModelFormatError, match="unknown model kind 'lookup_table'"):
        read_model_file(unknown)
    # a hybrid's network entries are checked as a network's
    arrays = {NETWORK_PREFIX + k: v for k, v in trained_net().to_arrays().items()}
    write_model(tmp_path / 'hybrid.npz', arrays, {'joint_names': np.array(['a'])},
                kind='hybrid')
    file = read_model_file(tmp_path / 'hybrid.npz')
    assert file.kind == 'hybrid' and file.metadata['joint_names'].tolist() == ['a']
    assert read_model_file(tmp_path / 'hybrid.npz', kind='hybrid').kind == 'hybrid'
    with pytest.raises(ModelFormatError, match='a hybrid model, not a network'):
        FeedForwardNet.load(tmp_path / 'hybrid.npz')
    with pytest.raises(ModelFormatError, match='a network model, not a physical one$'):
        read_model_file(good_file, kind='physical')
    arrays[NETWORK_PREFIX + 'params'] = np.zeros(3)
    write_model(tmp_path / 'bad_hybrid.npz', arrays, {}, kind='hybrid')
    with pytest.raises(ModelFormatError, match='corrupt hybrid model file: params'):
        read_model_file(tmp_path / 'bad_hybrid.npz')
