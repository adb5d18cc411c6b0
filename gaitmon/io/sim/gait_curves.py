"""The simulated leg's normative joint-angle curves over the gait cycle (``kinematics.py`` moves
the leg with them).

Hip, knee and ankle are 6-harmonic Fourier series in the gait-cycle phase q in [0, 1) (0 = heel
strike, 0.60 = toe off). The coefficients were fitted (periodic cubic spline through the key points
below, then the first six FFT harmonics; max deviation 0.3 deg hip, 0.5 deg knee, 1.4 deg ankle)
to values read off the ensemble-average sagittal curves of normal-cadence adults in

    D. A. Winter, *The Biomechanics and Motor Control of Human Gait: Normal, Elderly and
    Pathological*, 2nd ed., University of Waterloo Press, 1991 (ch. 3), also tabulated in
    D. A. Winter, *Biomechanics and Motor Control of Human Movement*, 4th ed., Wiley 2009, App. A.

Key points (% cycle: deg), clinical signs (hip flexion +, knee flexion +, ankle dorsiflexion +):

* hip:   0: 30, 10: 27, 20: 20, 30: 10, 40: 0, 50: -8, 55: -10, 60: -5, 65: 5, 70: 15, 75: 23,
  80: 30, 85: 33, 90: 33, 95: 31
* knee:  0: 5, 5: 12, 15: 18, 20: 17, 30: 10, 40: 5, 45: 6, 50: 10, 55: 20, 60: 37, 65: 52, 70: 62,
  73: 64, 75: 63, 80: 55, 85: 40, 90: 22, 95: 8
* ankle: 0: 0, 5: -5, 8: -6, 15: 0, 25: 5, 35: 8, 45: 10, 50: 7, 55: 0, 60: -12, 63: -17, 65: -16,
  70: -10, 75: -4, 80: 0, 90: 1

(``NORMATIVE_KEY_POINTS_DEG`` below; a test checks the series against them.)
"""

from __future__ import annotations

import numpy as np

from gaitmon.io.sim.jets import fourier_series

# Fourier series, degrees: value(q) = a0 + sum_k a_k cos(2 pi k q) + b_k sin(2 pi k q), k = 1..6.
HIP_COEFFS_DEG = (
    15.135,
    (19.656, -4.356, -0.359, -0.106, -0.197, 0.233),
    (-2.894, -2.640, 1.579, -0.397, 0.499, -0.055),
)
KNEE_COEFFS_DEG = (
    23.973,
    (-1.363, -15.231, -0.692, -0.897, -0.189, -0.269),
    (-21.415, 6.658, 3.771, 0.575, 0.814, 0.099),
)
ANKLE_COEFFS_DEG = (
    0.039,
    (-1.357, 1.174, -2.874, 2.100, 0.145, 0.327),
    (5.686, -6.795, 0.443, -0.513, -1.081, 0.336),
)

NORMATIVE_KEY_POINTS_DEG: dict[str, tuple[tuple[float, float], ...]] = {
    "hip": ((0, 30), (10, 27), (20, 20), (30, 10), (40, 0), (50, -8), (55, -10), (60, -5), (65, 5),
            (70, 15), (75, 23), (80, 30), (85, 33), (90, 33), (95, 31)),
    "knee": ((0, 5), (5, 12), (15, 18), (20, 17), (30, 10), (40, 5), (45, 6), (50, 10), (55, 20),
             (60, 37), (65, 52), (70, 62), (73, 64), (75, 63), (80, 55), (85, 40), (90, 22),
             (95, 8)),
    "ankle": ((0, 0), (5, -5), (8, -6), (15, 0), (25, 5), (35, 8), (45, 10), (50, 7), (55, 0),
              (60, -12), (63, -17), (65, -16), (70, -10), (75, -4), (80, 0), (90, 1)),
}  # fmt: skip


def normative_joint_deg(q: np.ndarray) -> np.ndarray:
    """(N,) cycle phase in [0, 1) -> (N, 3) normative hip, knee, ankle in degrees."""
    return np.stack(
        [fourier_series(c, q)[0] for c in (HIP_COEFFS_DEG, KNEE_COEFFS_DEG, ANKLE_COEFFS_DEG)],
        axis=-1,
    )
