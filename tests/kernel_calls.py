"""Positional shorthands for the kernels' record-taking functions, for tests written by hand."""
from __future__ import annotations

from sweep.kernels.finger import closing_constants, closing_contact, reconfigure, solve_finger
from sweep.kernels.records import NO_EFFECTS, FingerModel, SolverSettings
from sweep.model import DEFAULT_STEP_RESOLUTION, STREAMLINE_STEP, TRAJECTORY_SLIDING


def solver_settings(step, root_tol) -> SolverSettings:
    """The accuracy record with the default trajectory method (finger solves ignore it)."""
    return SolverSettings(float(step), float(root_tol), TRAJECTORY_SLIDING, STREAMLINE_STEP,
                          DEFAULT_STEP_RESOLUTION)


def finger_model(l1, l2, r1, r2, r, mu_s, theta2_min, theta2_max) -> FingerModel:
    return FingerModel(float(l1), float(l2), float(r1), float(r2), float(r), float(mu_s),
                       float(theta2_min), float(theta2_max))


def solve(dx, dy, l1, l2, r1, r2, r, mu_s, theta2_min, theta2_max, step, root_tol):
    """solve_finger -> (mode, t1, t2, k1, k2, tip_overlap)."""
    return solve_finger(float(dx), float(dy),
                        finger_model(l1, l2, r1, r2, r, mu_s, theta2_min, theta2_max),
                        solver_settings(step, root_tol), NO_EFFECTS)


def closing(dx, dy, l1, l2, r, theta2_min, theta2_max):
    """closing_contact (geometry only) -> (mode, t1, t2, k1, k2, tip_overlap)."""
    finger = finger_model(l1, l2, 1.0, 1.0, r, 0.0, theta2_min, theta2_max)
    return closing_contact(float(dx), float(dy), finger, closing_constants(finger), NO_EFFECTS)


def reconfig(dx, dy, t1, l1, l2, r1, r2, r, mu_s, theta2_min, theta2_max, step, root_tol):
    """reconfigure -> (mode, t1, t2, k1, k2, tip_overlap)."""
    return reconfigure(float(dx), float(dy), float(t1),
                       finger_model(l1, l2, r1, r2, r, mu_s, theta2_min, theta2_max),
                       solver_settings(step, root_tol), NO_EFFECTS)
