"""Estimation on synthetic truth: planted errors (1 mm / 1 mrad on every joint origin, 10 mrad on
every zero, an unknown device frame), 60 fitted configurations with 20 um noise, 40 held out."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics.algorithms.calibration import calibrate, select_poses
from kinematics.algorithms.calibration.synthetic import experiment, plant
from kinematics.engine.poe import compile_model
from kinematics.errors import CalibrationError, UnknownLinkError
from kinematics.io.urdf import parse_urdf
from kinematics.spatial.lie import so3_log

SIGMA = 20e-6
CHAINS = [("ur5", "tool0"), ("panda", "panda_link8"), ("puma560_standard", None), ("stanford_arm", None)]


def fk_prediction(cal, Q):
    """What the calibrated model's own FK, with the returned base and point/tool, says the device sees."""
    tool = cal.tool if cal.tool is not None else np.block([[np.eye(3), cal.point[:, None]], [np.zeros((1, 3)), 1.0]])
    return cal.base @ compile_model(cal.model).fk(Q, [cal.link], tool=tool)[:, 0]


def scenario(catalogue, mid, link, measure, seed=3, outliers=()):
    model = catalogue.get(mid)
    link = link or model.links[-1]
    rng = np.random.default_rng(seed)
    truth, Q, data = experiment(model, link, measure, 100, rng, SIGMA, outliers=outliers)
    return model, link, truth, Q, data


@pytest.fixture(scope="module")
def results(catalogue):
    out = {}
    for mid, link in CHAINS:
        for measure in ("position", "pose"):
            model, link_, truth, Q, data = scenario(catalogue, mid, link, measure)
            kw = {"positions": data} if measure == "position" else {"poses": data}
            out[mid, measure] = (truth, Q, calibrate(model, link_, Q, holdout=0.4, random_seed=1, **kw))
    return out


@pytest.mark.parametrize("mid", [m for m, _ in CHAINS])
@pytest.mark.parametrize("measure", ["position", "pose"])
def test_held_out_predictions_reach_the_noise_limit(results, mid, measure):
    truth, Q, cal = results[mid, measure]
    held = np.array(cal.holdout)
    assert len(held) == 40 and cal.outliers == []
    pred = fk_prediction(cal, Q[held])
    err = np.linalg.norm(pred[:, :3, 3] - truth.predict(Q[held])[:, :3, 3], axis=1)
    rms_truth = float(np.sqrt(np.mean(err ** 2)))
    limit = SIGMA * np.sqrt(cal.identifiable / 60)  # sigma sqrt(p / M)
    assert rms_truth < 1.25 * limit
    assert cal.rmse_before > 2e-3  # the nominal model is millimetres off
    assert cal.rmse_after < 1.2 * SIGMA * np.sqrt(3)  # the fit leaves the noise
    assert cal.holdout_rmse < 1.3 * SIGMA * np.sqrt(3)
    assert cal.max_after >= cal.rmse_after
    R = sum(j.type != "prismatic" for j in cal.error_model.joints)
    P = len(cal.error_model.joints) - R
    assert cal.identifiable == 4 * R + 2 * P + (3 if measure == "position" else 6)
    assert np.isfinite(cal.condition_number) and cal.condition_number >= 1


@pytest.mark.parametrize("mid", ["ur5", "stanford_arm"])
def test_the_calibrated_models_fk_predicts_the_error_model(results, mid):
    truth, Q, cal = results[mid, "pose"]
    assert np.abs(fk_prediction(cal, Q) - cal.error_model.predict(Q, cal.x)).max() < 1e-12
    # and the tool rotation too, against the noise-free truth
    R_err = np.swapaxes(fk_prediction(cal, Q)[:, :3, :3], 1, 2) @ truth.predict(Q)[:, :3, :3]
    assert np.abs(R_err - np.eye(3)).max() < 1e-4


def test_sigmas_are_the_spread_of_the_estimates(catalogue):
    """Refitting the same robot under fresh noise, each parameter scatters as its sigma says."""
    model, link, truth, Q, _ = scenario(catalogue, "ur5", "tool0", "position")
    rng = np.random.default_rng(7)
    fits = [calibrate(model, link, Q[:60], positions=truth.measure(Q[:60], SIGMA, rng)) for _ in range(20)]
    names = [p["name"] for p in fits[0].parameters]
    assert all([p["name"] for p in f.parameters] == names for f in fits)
    values = np.array([[p["value"] for p in f.parameters] for f in fits])
    # the base's rotations are corrections of each fit's own registration: compare the rotations
    for f, row in zip(fits, values):
        phi = so3_log(f.base[:3, :3] @ fits[0].base[:3, :3].T)  # about the device's x, y, z axes
        for k, c in enumerate(("rx", "ry", "rz")):
            row[names.index(f"base.{c}")] = phi[k]
    sigmas = np.median([[p["sigma"] for p in f.parameters] for f in fits], axis=0)
    ratio = values.std(axis=0, ddof=1) / sigmas
    assert np.all((ratio > 0.45) & (ratio < 1.8)), dict(zip(names, ratio.round(2)))
    assert 0.75 < np.median(ratio) < 1.3


def test_the_calibrated_urdf_loads_in_pinocchio_with_the_same_fk(results):
    pytest.importorskip("pinocchio")
    from kinematics.verify.pinocchio import compare_fk

    for mid in ("ur5", "stanford_arm"):
        truth, Q, cal = results[mid, "position"]
        dev = compare_fk(cal.model, Q[:10], [cal.link])
        assert max(dev.max_position_error, dev.max_rotation_error) < 1e-9
        again = parse_urdf(cal.urdf)
        assert np.abs(compile_model(again).fk(Q[:5], [cal.link]) - compile_model(cal.model).fk(Q[:5], [cal.link])).max() == 0


def test_huber_names_the_outliers_and_they_do_no_harm(catalogue):
    bad = [3, 17, 42]
    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position", seed=5, outliers=bad)
    robust = calibrate(model, link, Q[:60], positions=data[:60], loss="huber")
    plain = calibrate(model, link, Q[:60], positions=data[:60], loss="linear")
    assert robust.outliers == bad
    test = Q[60:]

    def rms(cal):
        e = fk_prediction(cal, test)[:, :3, 3] - truth.predict(test)[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))

    clean = calibrate(model, link, np.delete(Q[:60], bad, 0), positions=np.delete(data[:60], bad, 0))
    assert rms(robust) < 1.05 * rms(clean)
    assert rms(plain) > 5 * rms(robust)  # the linear fit is dragged by them
    assert robust.rmse_after < 1.2 * SIGMA * np.sqrt(3)


def test_joint_offsets_only_fits_the_zeros(catalogue):
    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position")
    cal = calibrate(model, link, Q[:60], positions=data[:60], parameters="joint_offsets")
    names = {p["name"] for p in cal.parameters}
    assert {n for n in names if not n.startswith(("base.", "tool."))} == {
        f"{j}.offset" for j in model.joint_names[1:-1]}
    assert cal.identifiable == 13
    assert cal.rmse_after < cal.rmse_before
    # the origins are untouched except for the rotation about each joint axis
    for j_old, j_new in zip(model.joints, cal.model.joints):
        assert np.allclose(j_old.origin[:3, 3], j_new.origin[:3, 3], atol=1e-15)


def test_chosen_poses_predict_better_than_random_ones(catalogue):
    model = catalogue.get("ur5")
    chosen = select_poses(model, "tool0", 15, "position", random_seed=0, point=(0.05, 0.03, 0.1))
    assert chosen.q.shape == (15, 6)
    assert np.all(chosen.q >= model.lower_limits) and np.all(chosen.q <= model.upper_limits)
    assert chosen.log_det > chosen.random_log_det and chosen.identifiable == 27
    test = model.sample_configurations(200, np.random.default_rng(99))
    errors = {"chosen": [], "random": []}
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        truth = plant(model, "tool0", "position", rng)
        for label, Q in (("chosen", chosen.q), ("random", model.sample_configurations(15, rng))):
            cal = calibrate(model, "tool0", Q, positions=truth.measure(Q, SIGMA, rng))
            e = fk_prediction(cal, test)[:, :3, 3] - truth.predict(test)[:, :3, 3]
            errors[label].append(np.sqrt(np.mean(np.sum(e ** 2, axis=1))))
    assert np.mean(errors["chosen"]) < np.mean(errors["random"])


@pytest.mark.parametrize("change,match", [
    (lambda Q, P: (Q[:5], P[:5]), "not more than"),
    (lambda Q, P: (Q, np.where(np.arange(len(P))[:, None] == 7, np.nan, P)), "measurement 7"),
    (lambda Q, P: (Q[:, :5], P), "6 values"),
    (lambda Q, P: (np.repeat(Q[:1], len(Q), 0), P), "same configuration"),
])
def test_bad_measurements_are_refused_naming_the_problem(catalogue, change, match):
    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position")
    Qb, Pb = change(Q[:60], data[:60])
    with pytest.raises(CalibrationError, match=match):
        calibrate(model, link, Qb, positions=Pb)


def test_an_unknown_link_is_refused(catalogue):
    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position")
    with pytest.raises(UnknownLinkError):
        calibrate(model, "nope", Q, positions=data)


@pytest.mark.parametrize("link,count", [("right_finger", (17, 20)), ("left_tip", (15, 18))])
def test_a_tree_with_mimic_prismatic_continuous_and_oblique_axes(link, count):
    """The fixture's right branch: a revolute, a continuous, a prismatic and a mimic joint (driven by
    the other branch's elbow); the left: oblique axes and a fixed tip."""
    from tests.paths import FIXTURES
    from kinematics.io.urdf import load_urdf
    from kinematics.verify.pinocchio import compare_fk

    model = load_urdf(FIXTURES / "tree_mimic.urdf")
    for measure, want in zip(("position", "pose"), count):
        rng = np.random.default_rng(0)
        truth, Q, data = experiment(model, link, measure, 100, rng, SIGMA)
        kw = {"positions": data} if measure == "position" else {"poses": data}
        cal = calibrate(model, link, Q, holdout=0.4, **kw)
        assert cal.identifiable == want
        err = fk_prediction(cal, Q)[:, :3, 3] - truth.predict(Q)[:, :3, 3]
        assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 1.25 * SIGMA * np.sqrt(want / 60)
        dev = compare_fk(cal.model, Q[:5], [link])
        assert max(dev.max_position_error, dev.max_rotation_error) < 1e-9


def test_a_link_without_moving_joints_is_refused(catalogue):
    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position")
    with pytest.raises(CalibrationError, match="no moving joint"):
        calibrate(model, model.root, Q, positions=data)


def test_a_cancelled_calibration_stops(catalogue):
    from kinematics.engine.cancel import Cancellation, cancellable
    from kinematics.errors import CancelledError

    model, link, truth, Q, data = scenario(catalogue, "ur5", "tool0", "position")
    token = Cancellation()
    token.cancel()
    with cancellable(token), pytest.raises(CancelledError):
        calibrate(model, link, Q, positions=data)
    with cancellable(token), pytest.raises(CancelledError):
        select_poses(model, link, 10)
