"""The SGHQF's sparse-grid Gauss–Hermite rules against an independent implementation, chaospy (PyPI),
point by point.

Our rules come from the binary (`attitude-lab quadrature`, the core's `filters::sghqf::rule`).
chaospy builds Smolyak sparse grids from its own univariate Gaussian rules for N(0, 1) (Golub–Welsch
on the Stieltjes recurrence) and its own combination code:

* linear growth (m = l univariate points): `chaospy.quadrature.sparse_grid(L - 1, Iid(Normal(0, 1), n),
  rule="gaussian")`, its public API;
* odd growth (m = 2l - 1, the rule the filter uses): chaospy's Smolyak combination
  (`_construct_collection` of `chaospy.quadrature.sparse_grid`, pinned by the version in
  scripts/python-tests.sh) over chaospy's univariate rules of 1, 3, 5, … points; only the choice of
  univariate rules per level is ours (the growth rule's definition).

Both sides merge coincident points (chaospy keeps centres that differ by rounding apart), drop merged
weights below 1e-13 (cancellations to rounding) and are sorted; then every point and weight must
agree to 1e-12. chaospy missing is a failure, never a skip: scripts/python-tests.sh installs it.
"""

from __future__ import annotations

import json
import subprocess
import sys

import chaospy  # noqa: F401  (a missing oracle fails here, loudly)
import numpy as np
import pytest

from conftest import LAB

DIM = 6
#: Merged weights below this are cancellations to rounding, not points (the core's MERGED_ZERO).
MERGED_ZERO = 1e-13
#: Nodes of different univariate rules are at least 0.1 apart; rounding keys merge what coincides.
KEY_DIGITS = 9


def ours(level: int, growth: str, dim: int = DIM) -> tuple[np.ndarray, np.ndarray]:
    if not LAB.exists():
        pytest.fail(f"{LAB} does not exist: build it (cargo build --release -p attitude-lab) or run scripts/python-tests.sh")
    out = subprocess.run(
        [str(LAB), "quadrature", "--dim", str(dim), "--level", str(level), "--growth", growth],
        check=True,
        capture_output=True,
        text=True,
        timeout=60,
    ).stdout
    rule = json.loads(out)
    assert (rule["dim"], rule["level"], rule["growth"], rule["degree"]) == (dim, level, growth, 2 * level - 1)
    return np.array(rule["points"], dtype=float).reshape(-1, dim), np.array(rule["weights"], dtype=float)


def merged(points: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coincident points merged, cancelled weights dropped, sorted lexicographically."""
    acc: dict[tuple, list] = {}
    for p, w in zip(points, weights):
        key = tuple(np.round(p, KEY_DIGITS) + 0.0)  # (+ 0.0 turns -0.0 into 0.0)
        if key in acc:
            acc[key][1] += w
        else:
            acc[key] = [p, w]
    kept = sorted((k, v) for k, v in acc.items() if abs(v[1]) > MERGED_ZERO)
    return np.array([v[0] for _, v in kept]), np.array([v[1] for _, v in kept])


def chaospy_linear(level: int, dim: int = DIM) -> tuple[np.ndarray, np.ndarray]:
    x, w = chaospy.quadrature.sparse_grid(level - 1, chaospy.Iid(chaospy.Normal(0, 1), dim), rule="gaussian")
    return x.T, w


def chaospy_odd(level: int, dim: int = DIM) -> tuple[np.ndarray, np.ndarray]:
    smolyak = sys.modules["chaospy.quadrature.sparse_grid"]
    normal = chaospy.Normal(0, 1)
    rules = [chaospy.quadrature.gaussian(2 * idx, normal) for idx in range(level)]  # 1, 3, 5, … points
    x_lookup = [[r[0][0] for r in rules] for _ in range(dim)]
    w_lookup = [[r[1] for r in rules] for _ in range(dim)]
    collection = smolyak._construct_collection(level - 1, chaospy.Iid(normal, dim), x_lookup, w_lookup)
    keys = list(collection)
    return np.array(keys, dtype=float), np.array([collection[k] for k in keys])


def compare(ours_rule, theirs_rule, what: str) -> None:
    (xa, wa), (xb, wb) = merged(*ours_rule), merged(*theirs_rule)
    assert len(wa) == len(wb), f"{what}: {len(wa)} points here, {len(wb)} in chaospy"
    dx, dw = np.abs(xa - xb).max(), np.abs(wa - wb).max()
    print(f"{what}: {len(wa)} points, max |Δx| = {dx:.1e}, max |Δw| = {dw:.1e}, "
          f"negative weights {int((wa < 0).sum())}, Σw = {wa.sum():.15f}")
    assert dx < 1e-12 and dw < 1e-12, f"{what}: max |Δx| = {dx}, max |Δw| = {dw}"


@pytest.mark.parametrize("level", [2, 3, 4])
def test_the_filters_rules_agree_with_chaospy_point_by_point(level):
    compare(ours(level, "odd"), chaospy_odd(level), f"odd growth, L = {level}")


@pytest.mark.parametrize("level", [1, 2, 3, 4])
def test_linear_growth_agrees_with_chaospys_public_sparse_grid(level):
    compare(ours(level, "linear"), chaospy_linear(level), f"linear growth, L = {level}")


def test_the_documented_sizes_and_centre_weights():
    # docs/algorithms.md §3 (SGHQF): 13, 97 and 533 points, centre weights −1, −2/15, 2/945.
    for level, count, centre in [(2, 13, -1.0), (3, 97, -2.0 / 15.0), (4, 533, 2.0 / 945.0)]:
        x, w = ours(level, "odd")
        assert len(w) == count and not x[0].any(), level
        assert abs(w[0] - centre) < 1e-12, (level, w[0])
