"""Rotation helpers against scipy, the reference, including the identity and angles near pi."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from elastyle.core.rotations import continuous_log, from_matrix, multiply, slerp_resample, to_matrix, to_quat


def _random_rotvecs(count: int) -> np.ndarray:
    rotvecs = Rotation.random(count, random_state=1).as_rotvec()  # angles spread over [0, pi]
    rotvecs[:3] = [[0, 0, 0], [np.pi - 1e-7, 0, 0], [0, 1e-9, 0]]  # identity, near pi, tiny
    return rotvecs


def test_matrices_match_scipy() -> None:
    rotvecs = _random_rotvecs(500)
    np.testing.assert_allclose(to_matrix(rotvecs), Rotation.from_rotvec(rotvecs).as_matrix(), atol=1e-12)
    back = from_matrix(to_matrix(rotvecs))
    np.testing.assert_allclose(to_matrix(back), to_matrix(rotvecs), atol=1e-9)


def test_matrix_to_exp_map_is_exact_at_every_angle() -> None:
    # angles from 0 to just below pi, dense around 162 degrees where the trace formula hands over
    angles = np.concatenate([np.linspace(0, np.pi - 1e-6, 2000), np.radians(np.linspace(160, 164, 500))])
    axes = Rotation.random(len(angles), random_state=2).as_rotvec()
    rotvecs = axes / np.linalg.norm(axes, axis=1, keepdims=True) * angles[:, None]
    np.testing.assert_allclose(from_matrix(to_matrix(rotvecs)), rotvecs, atol=1e-9)
    matrices = Rotation.from_rotvec(rotvecs).as_matrix()
    np.testing.assert_allclose(from_matrix(matrices), Rotation.from_matrix(matrices).as_rotvec(), atol=1e-12)


def test_quaternions_match_scipy_up_to_sign() -> None:
    rotvecs = _random_rotvecs(500)
    ours = to_quat(rotvecs)
    theirs = Rotation.from_rotvec(rotvecs).as_quat()
    np.testing.assert_allclose(np.abs(np.sum(ours * theirs, axis=-1)), 1.0, atol=1e-12)


def test_multiply_matches_scipy_and_broadcasts() -> None:
    a, b = _random_rotvecs(200), _random_rotvecs(200)[::-1]
    expected = (Rotation.from_rotvec(a) * Rotation.from_rotvec(b)).as_matrix()
    np.testing.assert_allclose(to_matrix(multiply(a, b)), expected, atol=1e-9)
    assert multiply(a[:1], b).shape == (200, 3)


def test_slerp_halfway() -> None:
    rotvecs = np.array([[[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]])
    middle = slerp_resample(rotvecs, np.array([0.5]))
    np.testing.assert_allclose(middle[0, 0], [0.0, 0.5, 0.0], atol=1e-12)


def test_slerp_matches_scipy() -> None:
    from scipy.spatial.transform import Slerp

    rotvecs = _random_rotvecs(40).reshape(20, 2, 3)
    times = np.linspace(0, 19, 77)
    ours = slerp_resample(rotvecs, times)
    for joint in range(2):
        expected = Slerp(np.arange(20), Rotation.from_rotvec(rotvecs[:, joint]))(times).as_matrix()
        np.testing.assert_allclose(to_matrix(ours[:, joint]), expected, atol=1e-9)
    assert np.all(np.linalg.norm(ours, axis=-1) <= np.pi + 1e-12)


def test_continuous_log_starts_below_a_half_turn_and_has_no_jumps() -> None:
    angles = np.linspace(0.5, 5.5, 60)  # a steady turn past pi about one axis
    rotvecs = np.stack([np.zeros(60), angles, np.zeros(60)], axis=1)[:, None]  # (60, 1, 3)
    wrapped = from_matrix(to_matrix(rotvecs))  # the same rotations, angles folded into [0, pi]
    continuous = continuous_log(wrapped)
    np.testing.assert_allclose(continuous[:, 0, 1], angles, atol=1e-9)
    # a clip that starts past a half turn (5.5 rad about -y) starts at that rotation's shorter way round
    backwards = -rotvecs[::-1]
    np.testing.assert_allclose(continuous_log(backwards)[0, 0, 1], 2 * np.pi - 5.5, atol=1e-9)


def test_least_turn_takes_each_direction_onto_its_target_even_the_opposite_one() -> None:
    """Random directions, one pair pointing exactly opposite ways and one the same way: each turn takes its
    source onto its target's direction (an opposite pair by a half turn), and `best_rotation` of one bone
    does too (it turned an opposite bone by 135 degrees instead of 180)."""
    from elastyle.core.rest_frames import best_rotation
    from elastyle.core.rotations import least_turn

    rng = np.random.default_rng(0)
    sources, targets = rng.standard_normal((2, 20, 3))
    targets[3], targets[4] = -2.0 * sources[3], 3.0 * sources[4]
    turns = least_turn(sources, targets)
    turned = np.einsum("nij,nj->ni", to_matrix(turns), sources)
    cosines = (
        np.sum(turned * targets, -1) / np.linalg.norm(turned, axis=-1) / np.linalg.norm(targets, axis=-1)
    )
    np.testing.assert_allclose(cosines, 1.0, atol=1e-9)
    assert np.linalg.norm(turns[3]) == pytest.approx(np.pi) and np.linalg.norm(turns[4]) == 0.0
    np.testing.assert_allclose(least_turn(sources[3], targets[3]), turns[3])
    one = best_rotation(sources[3][None], targets[3][None]) @ sources[3]
    assert one @ targets[3] / np.linalg.norm(one) / np.linalg.norm(targets[3]) == pytest.approx(1.0)
