"""The Dormand-Prince 5(4) tableau (Dormand & Prince 1980; Hairer, Norsett & Wanner, Solving ODEs I,
Sec. II.5) of the compiled DOPRI5 steps of the Hunt-Crossley contact phases (SDOF and beam).

``DP_C`` the nodes, ``DP_A`` the stage coefficients (row 6: the 5th-order weights, FSAL),
``DP_E`` the differences of the 5th- and 4th-order weights (the error estimate).
"""
from __future__ import annotations

import numpy as np

DP_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
DP_A = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                 [1 / 5, 0.0, 0.0, 0.0, 0.0, 0.0],
                 [3 / 40, 9 / 40, 0.0, 0.0, 0.0, 0.0],
                 [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0, 0.0],
                 [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0, 0.0],
                 [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0.0],
                 [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]])
DP_E = np.array([71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])
