"""The station's gauges: two per leg, named AXIS_LEG ("y_x": along y on the x leg)."""

from __future__ import annotations

from ogacq.model.parameters import AXES

GAUGE_KEYS: tuple[str, ...] = tuple(f"{AXES[j]}_{AXES[i]}"
                                    for i in range(3) for j in range(3) if j != i)
#: (gauge axis, leg) index pairs, in the order of GAUGE_KEYS.
GAUGE_INDICES: tuple[tuple[int, int], ...] = tuple(
    (AXES.index(key[0]), AXES.index(key[2])) for key in GAUGE_KEYS)
#: Two indicators moved from leg to leg (the papers' station): the gauges each one
#: serves, the first gauge of every leg for the first, the other for the second.
MOVED_INDICATORS: tuple[tuple[str, ...], ...] = (GAUGE_KEYS[0::2], GAUGE_KEYS[1::2])
