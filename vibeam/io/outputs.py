"""The per-point outputs of a sweep and their units: the one place they are defined.

:data:`UNITS` gives every per-point dataset's unit and meaning as ``"unit (what)"``: ``unit`` a UDUNITS
string without spaces (``mm``, ``N``, ``1``) and ``what`` the description, never left out (it becomes
the long_name); a text whose head has spaces (``"forcing periods recorded (...)"``) is a count, units
``1``, and is its own description.  The results
writer (:func:`vibeam.io.results.describe`) turns it into CF ``units`` and ``long_name``, and the
sweep engine (:mod:`vibeam.engine.sweep`) re-exports it.  :data:`MM_KEYS` are the displacements
a physical scene also stores in mm at the sensor (``<key>_mm``).
"""
from __future__ import annotations

# units of the per-point datasets (written as HDF5 attributes)
UNITS = {
    "Omega": "1 (forcing frequency / natural frequency)",
    "amplitude": "1 (Q = Delta - min q, paper Sec. 4.1)",
    "amplitude_mean": "1 (mean over the recorded periods of Q_k = Delta - min q over period k)",
    "amplitude_std": "1 (sample standard deviation of Q_k over the recorded periods)",
    "amplitude_min": "1 (smallest Q_k of the recorded periods)",
    "amplitude_max": "1 (largest Q_k of the recorded periods)",
    "amplitude_sem": "1 (standard error of amplitude_mean by batch means of the Q_k)",
    "amplitude_sem_dof": "degrees of freedom of amplitude_sem (batches - 1)",
    "record_periods": "forcing periods recorded (the sample size of the Q_k; statistics_periods for a "
                      "non-periodic point)",
    "transient_periods_used": "forcing periods simulated before the record",
    "amplitude_lower": "1 (lower branch of P(Q) = 0)",
    "q_max": "1", "q_min": "1",
    "period": "period-n of the stroboscopic map (0 = not periodic within 8, -1 = no impact)",
    "impacts_per_period": "1/forcing period (two stops: on the upper stop)",
    "impact_velocity": "1 (mean pre-impact velocity; two stops: on the upper stop)",
    "impacts_per_period_lower": "1/forcing period (impacts on the lower stop of a two-sided scene)",
    "impact_velocity_lower": "1 (mean pre-impact speed |q'-| on the lower stop)",
    "stop_impacts": "impacts recorded on each stop (stop 0 upper and 1 lower at the attached mass, 2 + i the "
                    "i-th [[model.stop]] at another point)",
    "stop_impacts_per_period": "1/forcing period (impacts on each stop; stops as stop_impacts)",
    "stop_impact_velocity": "1 (mean normal pre-impact speed on each stop, per L and time unit; stops as "
                            "stop_impacts)",
    "strobe": "1 ((q, q') at forcing phase 0 of each recorded period)",
    "harmonics": "1 (amplitudes of 0, 1, ..., 5 Omega)",
    "frequency_hz": "Hz (forcing frequency f)", "amplitude_mm": "mm (amplitude at the sensor)",
    "amplitude_mean_mm": "mm (mean over the recorded periods of the per-period amplitude at the sensor)",
    "amplitude_std_mm": "mm (sample standard deviation of the per-period amplitude at the sensor)",
    "amplitude_min_mm": "mm (smallest per-period amplitude at the sensor of the recorded periods)",
    "amplitude_max_mm": "mm (largest per-period amplitude at the sensor of the recorded periods)",
    "amplitude_sem_mm": "mm (standard error of amplitude_mean_mm by batch means)",
    "wall_time_s": "s (compute time of the point)",
    "effective_gain": "1/V (gamma at this frequency, platform filter)",
    "gap_mm": "mm (grazing gap at the sensor at this point, gap drift)",
    "gap_drift_mm": "mm (drift of the gap at the sensor)", "impulse_per_period": "1 (sum of (1 + R) U- per forcing period)",
    "stuck_fraction": "1 (share of the recorded window on the stop)",
    "contact_duration": "1 (mean duration of a contact, time unit 1/omega_n; 0 for an impulsive law; "
                        "two stops: on the upper stop)",
    "contact_force_max": "1 (largest contact force per unit effective mass, k L; NaN for an impulsive law; "
                         "two stops: on the upper stop)",
    "penetration_max": "1 (largest penetration of the stop; 0 for an impulsive law; two stops: the upper stop)",
    "energy_per_impact": "1 (mean energy lost per contact, k L^2 per unit effective mass; "
                         "two stops: on the upper stop)",
    "contact_duration_lower": "1 (mean duration of a contact on the lower stop of a two-sided scene)",
    "contact_force_max_lower": "1 (largest contact force on the lower stop of a two-sided scene, k L)",
    "penetration_max_lower": "1 (largest penetration of the lower stop of a two-sided scene)",
    "energy_per_impact_lower": "1 (mean energy lost per contact on the lower stop of a two-sided scene, k L^2)",
    "contact_fraction": "1 (share of the recorded window in contact with a compliant stop)",
    "contact_duration_s": "s (mean duration of a contact; 0 for an impulsive law; two stops: on the upper stop)",
    "contact_force_max_n": "N (largest contact force; NaN for an impulsive law; two stops: on the upper stop)",
    "penetration_max_mm": "mm (largest penetration of the stop, as a displacement at the sensor; 0 for an "
                          "impulsive law; two stops: the upper stop)",
    "energy_per_impact_j": "J (mean energy lost per contact; two stops: on the upper stop)",
    "lyapunov": "1/time unit (Lyapunov exponents of the stroboscopic map per unit nondimensional time, largest "
                "first; -inf: a direction a sticking phase collapses)",
    "lyapunov_error": "1/time unit (standard error of the exponents by batch means over the record; 0 for "
                      "Floquet exponents)",
    "lyapunov_qr": "1/time unit (the QR estimate of the exponents, kept beside Floquet exponents as a check)",
    "contact_duration_lower_s": "s (mean duration of a contact on the lower stop of a two-sided scene)",
    "contact_force_max_lower_n": "N (largest contact force on the lower stop of a two-sided scene)",
    "penetration_max_lower_mm": "mm (largest penetration of the lower stop of a two-sided scene, as a "
                                "displacement at the sensor)",
    "energy_per_impact_lower_j": "J (mean energy lost per contact on the lower stop of a two-sided scene)",
}


# per-point displacements that physical scenes also store in mm at the sensor (``<key>_mm``)
MM_KEYS = ("amplitude", "amplitude_mean", "amplitude_std", "amplitude_min", "amplitude_max", "amplitude_sem",
           "penetration_max",
           "penetration_max_lower")
