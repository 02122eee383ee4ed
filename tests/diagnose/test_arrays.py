"""``ogacq.diagnose.arrays`` gives numpy's own ``unique`` and ``median`` values, bit for
bit (signed zeros and NaNs included), on arrays like a campaign's positions."""

import numpy as np
import pytest

from ogacq.diagnose.arrays import median, sorted_distinct


def _arrays(seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for n in range(1, 40):
        for _ in range(20):
            x = np.round(rng.normal(size=n) * 10.0 ** rng.integers(-3, 4), rng.integers(0, 9))
            for special in (np.nan, -0.0, 0.0):
                if rng.random() < 0.25:
                    x[rng.integers(0, n, size=rng.integers(1, n + 1))] = special
            out.append(x)
    return out


@pytest.mark.parametrize("seed", [0, 1])
def test_the_same_values_as_numpy(seed: int) -> None:
    for x in _arrays(seed):
        assert sorted_distinct(x).tobytes() == np.unique(x).tobytes(), x
        with np.errstate(invalid="ignore"):
            expected = np.float64(np.median(x))
        assert np.float64(median(x)).tobytes() == expected.tobytes() or (
            np.isnan(expected) and np.isnan(median(x))), x


def test_empty() -> None:
    assert len(sorted_distinct(np.array([]))) == 0
