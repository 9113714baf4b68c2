"""Constants and numpy models of the Causal Chambers (Gamella, Peters, Buehlmann 2025).

The physical constants of the wind and light tunnels, from the publisher's code and calibration,
live here with the science models that use them (:mod:`sklearn_hybrid.models.science`); the
data loaders and the simulated stand-ins (:mod:`sklearn_hybrid.datasets`) read them from here.
"""

from __future__ import annotations

import numpy as np

__all__ = ["L_MIN", "OMEGA_MAX", "S_MAX", "Q_MAX", "R_CODE", "R_REFERENCE", "C3_R0", "C3_BETA", "FAN_INERTIA",
           "TORQUE_T", "C_MIN", "C_MAX", "FAN_DRAG_K", "BAROMETER_PRECISION", "S_CAMERA", "W_WHITE_BALANCE",
           "EXPOSURE_F3", "T_PARALLEL", "T_CROSSED", "HEX_CENTER_X", "HEX_CENTER_Y", "HEX_RADIUS", "HEX_OFFSET",
           "hexagon_mask", "model_f3_colour"]

# Constants. Source: juangamella/causal-chamber-package (causalchamber/models/*.py, simulators,
# tutorial_SimsAXCX / tutorial_ModelsF) and juangamella/causal-chamber-paper
# (case_studies/mechanistic_models.ipynb); paper appendix IV (arXiv 2404.11341).
# Wind tunnel, models A1, A2, C2, C3 (SI units, angular speeds in rad/s).
L_MIN = 0.1  # load below which the fan runs at L_MIN (A1, B1)
OMEGA_MAX = 3000 * np.pi / 30  # 3000 rpm in rad/s
S_MAX = 74.82473949999999  # Pa, maximum static pressure of a fan
Q_MAX = 186.7 / 3600  # m^3/s, maximum airflow of a fan (cancels out of C2)
R_CODE = 0.75  # impedance ratio r of C2 in the publisher's code
R_REFERENCE = 0.7  # reference r of the hybrid paper ("suggested in the paper and the codes")
C3_R0, C3_BETA = 0.75, 0.15  # C3: r(H) = min(1, r0 + beta * H / 45)
FAN_INERTIA = 0.5 * 0.059**2 * 0.02  # kg m^2, I of model A2
TORQUE_T, C_MIN, C_MAX = 0.05, 0.166, 0.27  # A2 torque constant; B1 currents in A
FAN_DRAG_K = TORQUE_T * (C_MAX - C_MIN) / OMEGA_MAX**2  # K = tau(1) / omega_max^2
BAROMETER_PRECISION = 0.2  # Pa, std of the simulated barometer noise
# Light tunnel, model F3 (rows of S: camera channel R, G, B; columns: LED colour R, G, B).
S_CAMERA = np.array([[0.2995802, 0.06920322, 0.028159],
                     [0.04017132, 0.9209918, 0.31265],
                     [0.00217392, 0.2071558, 0.75763]])
W_WHITE_BALANCE = np.array([2.65625, 1.0, 1.77344])  # w_R, w_G, w_B
EXPOSURE_F3 = 2.5  # e of F3 (F2 uses 0.8)
T_PARALLEL = np.array([0.29, 0.35, 0.33])  # T^p, polarizers parallel
T_CROSSED = np.array([0.02, 0.08, 0.18])  # T^c, polarizers crossed
HEX_CENTER_X, HEX_CENTER_Y, HEX_RADIUS, HEX_OFFSET = 0.5, 0.5, 0.22, 0.0  # fractions, rad


def hexagon_mask(image_size: int) -> np.ndarray:
    """Boolean (H, W) mask of the light-source hexagon, as in the publisher's F models."""
    cols = np.arange(image_size)
    X, Y = np.meshgrid(cols, cols[::-1])  # X = column index, Y = flipped row index
    angles = np.arange(6) * np.pi / 3 + HEX_OFFSET
    vx = (HEX_CENTER_X + HEX_RADIUS * np.cos(angles)) * image_size
    vy = (HEX_CENTER_Y + HEX_RADIUS * np.sin(angles)) * image_size
    sx, sy = vx - np.roll(vx, -1), vy - np.roll(vy, -1)
    cross = (X[None] - vx[:, None, None]) * sy[:, None, None] - \
        (Y[None] - vy[:, None, None]) * sx[:, None, None]
    return (cross <= 0).all(axis=0) | (cross > 0).all(axis=0)


def model_f3_colour(X: np.ndarray) -> np.ndarray:
    """Colour (n, 3) in [0, 1] of model F3 with the publisher's constants, X in raw units.

    c = clip(e diag(w) S x * m) with x = (R, G, B) / 255 and the transmission
    m = (T^p - T^c) cos^2(theta_1 - theta_2) + T^c applied per camera channel, as in the
    publisher's code (the hybrid paper's equation writes S diag(m) x instead).
    """
    x = np.asarray(X, dtype=float)
    malus = np.cos(np.deg2rad(x[:, 3] - x[:, 4])) ** 2
    m = (T_PARALLEL - T_CROSSED) * malus[:, None] + T_CROSSED
    sensed = (x[:, :3] / 255) @ S_CAMERA.T  # camera channels, one row per sample
    return np.clip(EXPOSURE_F3 * W_WHITE_BALANCE * sensed * m, 0, 1)
