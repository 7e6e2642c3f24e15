"""Closest robot-robot approach between samples (plants/flycrane/collisions.py,
controllers/planner/clearance.py): closed form against dense sampling, and the value one
experiment reports against the geometry."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netcosim.plants.flycrane.collisions import (
    SAFETY_DISTANCE,
    chord_error_bound,
    min_pairwise_distance,
    segment_min_distance,
)

coord = st.floats(-3.0, 3.0, allow_nan=False)
point = st.tuples(coord, coord, coord)


@settings(max_examples=200, deadline=None)
@given(point, point, point, point, st.floats(0.1, 5.0))
def test_segment_closed_form_matches_dense_sampling(pa0, pa1, pb0, pb1, T):
    d, t = segment_min_distance(pa0, pa1, pb0, pb1, T)
    s = np.linspace(0.0, 1.0, 20001)[:, None]
    rel = (np.asarray(pa0) - np.asarray(pb0)) * (1 - s) + (np.asarray(pa1) - np.asarray(pb1)) * s
    dense = np.linalg.norm(rel, axis=1)
    assert d <= dense.min() + 1e-12                       # never above any sampled distance
    # the sampled minimum is at most half a grid step of relative motion above the true one
    step = np.linalg.norm((np.asarray(pa1) - np.asarray(pb1)) - (np.asarray(pa0) - np.asarray(pb0))) / 20000
    assert dense.min() - d <= step / 2 + 1e-12
    assert 0.0 <= t <= T
    at_t = np.linalg.norm(rel[0] + (rel[-1] - rel[0]) * t / T)
    assert at_t == pytest.approx(d, abs=1e-12)


def test_crossing_robots_known_minimum():
    # a along x, b along y 0.3 m higher: they pass over each other at t = 1 s
    d, t = segment_min_distance((-1, 0, 0), (1, 0, 0), (0, -1, 0.3), (0, 1, 0.3), T=2.0)
    assert d == pytest.approx(0.3, abs=1e-15) and t == pytest.approx(1.0, abs=1e-15)
    # at the samples they are sqrt(2 + 0.09) m apart: only the between-sample check sees the contact
    ca = min_pairwise_distance([0.0, 2.0], [[(-1, 0, 0), (0, -1, 0.3)], [(1, 0, 0), (0, 1, 0.3)]])
    assert ca.at_sample == pytest.approx(math.sqrt(2.09))
    assert ca.distance == pytest.approx(0.3) and ca.time == pytest.approx(1.0) and ca.pair == (0, 1)
    assert ca.below_safety and SAFETY_DISTANCE == 0.5


def test_chord_error_bounds_a_curved_path():
    # robot 0 on a circle of radius 1 around robot 1 (fixed) sampled every 0.5 rad, plus a
    # third robot far away: the chords come inside the circle by 1 - cos(0.25)
    th = np.arange(0.0, 2 * np.pi, 0.5)
    P = np.zeros((th.size, 3, 3))
    P[:, 0, 0], P[:, 0, 1] = np.cos(th), np.sin(th)
    P[:, 2, 0] = 10.0
    ca = min_pairwise_distance(th, P, chord_error=None)
    assert ca.distance == pytest.approx(math.cos(0.25), rel=1e-12)
    assert ca.distance + ca.chord_error >= 1.0                 # the bound covers the true distance
    assert ca.chord_error == pytest.approx(chord_error_bound(th, P))
    assert ca.chord_error < 0.1


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="T must be a positive"):
        segment_min_distance((0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), T=0.0)
    with pytest.raises(ValueError, match="strictly increasing"):
        min_pairwise_distance([0.0, 0.0], np.zeros((2, 2, 3)))


def test_ch4_fig4_8_9_reports_the_start_geometry():
    """The ch. 4 runs start with all cable angles at 80 deg (q_2) or 65 deg (q_1) and open
    them: adjacent robots are closest at the start, ``sqrt(2) (1/2 + r cos alpha)`` apart
    with ``r = 1.5 sin(acos(1/3)) = sqrt(2)`` m, and never closer between samples."""
    from netcosim.experiments import ch4_fig4_8_9 as ex
    samples, _ = ex.run(quick=True, n_mu=8)
    c = ex.clearance(samples)
    assert len(c) == 8 and not c.below_safety.any()
    for ic, deg in ex.INITIAL_DEG.items():
        want = math.sqrt(2) * (0.5 + math.sqrt(2) * math.cos(math.radians(deg)))
        rows = c[c.initial == ic]
        assert rows.min_distance.to_numpy() == pytest.approx(want, abs=1e-9)
        assert (rows.t_min_distance == 0.0).all()
        assert (rows.chord_error < 0.01).all()
    assert want == pytest.approx(1.054403, abs=1e-6)
