"""The bank stores a parameter shared by all loops once, and every loop reads its exact row."""

from __future__ import annotations

import numpy as np
import pytest

from ctrlblocks.fast import PIDBank
from ctrlblocks.fast import bank as bank_mod


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float).view(np.int64)


@pytest.mark.parametrize("chunk", [7, 1 << 16])
def test_columns_hold_exactly_the_rows_of_every_loop(monkeypatch, chunk):
    monkeypatch.setattr(bank_mod, "_CHUNK", chunk)  # 7: three chunks of rows, and a short one
    rng = np.random.default_rng(3)
    n = 20
    kp, ti, td = rng.uniform(1, 3, n), rng.uniform(4, 9, n), rng.uniform(0, 2, n)
    u_min = np.where(np.arange(n) % 2, 0.0, -0.0)  # equal values, different bits: kept apart
    k, t = rng.uniform(0.5, 2, n), rng.uniform(1, 5, (n, 2))
    bank = PIDBank.from_arrays(kp=kp, ti=ti, td=td, ts=0.1, u_min=u_min, u_max=5.0,
                               plant_k=k, plant_t=t)  # fmt: skip
    want_prm = np.empty((n, 13))
    bank_mod._fill_rows(want_prm, kp, ti, td, np.full(n, 10.0), np.ones(n), np.zeros(n), 0.1,
                        u_min, np.full(n, 5.0), np.zeros(n, dtype=bool), 1, 2, 0.0,
                        np.zeros(n))  # fmt: skip
    want_pp = np.empty((n, 15))
    bank_mod._chain_zoh(want_pp, k, t, 0.1)
    np.testing.assert_array_equal(_bits(bank.prm), _bits(want_prm))
    np.testing.assert_array_equal(_bits(bank.pp), _bits(want_pp))
    # stored per loop: k, a, bd, K h/Ti, g, u_min (its sign bit varies) of the PID; phi's
    # lower triangle of the 2 lags (3) and gamma0 (2) of the plant
    assert bank.stored_bytes == bank.state_bytes + 8 * (6 + 5)
    assert bank.param_bytes == 224


def test_a_tuning_study_on_lag_chains_stores_under_200_bytes_per_loop():
    rng = np.random.default_rng(1)
    n = 1000
    bank = PIDBank.from_arrays(kp=rng.uniform(2, 6, n), ti=rng.uniform(5, 17, n),
                               td=rng.uniform(0.5, 3, n), ts=0.1, u_min=0.0, u_max=5.0,
                               plant_k=rng.uniform(0.5, 1.0, n),
                               plant_t=rng.uniform(1.0, 8.0, (n, 3)))  # fmt: skip
    assert bank.stored_bytes == 80 + 8 * (5 + 9) == 192


def test_identical_loops_store_no_parameter_column():
    bank = PIDBank.from_arrays(kp=2.0, ti=5.0, td=1.0, ts=0.1, plant_k=1.0,
                               plant_t=np.ones((6, 3)))  # fmt: skip
    assert bank.stored_bytes == bank.state_bytes
    res = bank.run(1.0, 300)
    assert np.all(res.y == res.y[0]) and abs(res.y[0] - 1.0) < 0.05
