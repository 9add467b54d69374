"""identification_mse's layout: what encode_mse writes, decode_mse reads back."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification.metrics import error_stats
from scara_ident_ros.mse_layout import METRICS_LABEL, decode_mse, encode_mse


def test_encode_then_decode_gives_each_metric_per_joint_and_total() -> None:
    stats = error_stats(np.array([1.0, 4.0]), np.array([2.0, 8.0]), np.array([2.0, 8.0]), 10)
    validation = error_stats(np.array([3.0, 3.0]), np.array([1.0, 3.0]),
                             np.array([1.0, 3.0]), 5)
    dims, data = encode_mse(['a', 'b'], stats, validation)
    assert [tuple(d) for d in dims] == [(METRICS_LABEL, 3, 9), ('joint:a,b,total', 3, 3)]
    rows = decode_mse(data, 2)
    np.testing.assert_allclose(rows['mse'], [1.0, 4.0, 2.5])
    np.testing.assert_allclose(rows['nmse'], [0.5, 0.5, 0.5])
    np.testing.assert_allclose(rows['validation_nmse'], [3.0, 1.0, 2.0])
    _, data = encode_mse(['a', 'b'], stats, None)
    assert np.isnan(decode_mse([data, data], 2)['validation_nmse']).all()


def test_old_two_row_messages_and_wrong_lengths() -> None:
    assert set(decode_mse(np.zeros(6), 2)) == {'mse', 'nmse'}
    with pytest.raises(ValueError, match='not 2 or 3 rows'):
        decode_mse(np.zeros(7), 2)
