"""Hand-chosen mutants and the default-step tests that must catch each one.

Each mutant is a small plausible bug: one exact text replacement in one source file.  Run::

    .venv/bin/python tests/mutants.py            # every mutant
    .venv/bin/python tests/mutants.py 3 7        # some of them (numbers of ``--list``)
    .venv/bin/python tests/mutants.py --list

For each mutant the file is changed, its tests run (``pytest -x -q``, the default step's
markers: no slow test may be needed to catch a mutant), and the file restored byte for byte
(also on Ctrl-C).  A mutant is *killed* when pytest exits 1 (a test failed); it *survives* when
the tests pass (exit 0); anything else (collection error, exit 2-5) is reported as an error of the
list, as is a replacement text that no longer occurs exactly once.  The exit code is 0 only
when every mutant was killed.  The numba cache is keyed on the whole ``models/`` package, so a
mutant of a kernel recompiles the kernels it touches (up to a minute each).  The list is kept in
``tests/README.md`` ("Mutation run").
"""
from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    what: str           # the bug, in words
    file: str           # path from the repository root
    old: str            # exact text, occurring once
    new: str
    tests: tuple        # pytest node ids (or files) that must catch it


MUTANTS: list[Mutant] = [
    # --- laws and stops
    Mutant("a lower stop rebounds with the upper stop's R (Newton's law, the event integrator)",
           "models/core/integrator.py",
           "Rc = restitution_coefficient(Um, st.R[k_imp], st.tab_U[k_imp, :m_nodes], st.tab_R[k_imp, :m_nodes])",
           "Rc = restitution_coefficient(Um, st.R[0], st.tab_U[k_imp, :m_nodes], st.tab_R[k_imp, :m_nodes])",
           ("tests/test_contact_outputs_two.py", "tests/test_energy_balance.py")),
    Mutant("mixed stops: every stop's R is the first stop's (the Newton lower stop takes the compliant "
           "upper stop's R) in the kernels' stops",
           "models/core/stops.py", "np.ascontiguousarray(par[:, RCOL]),", "np.full(par.shape[0], par[0, RCOL]),",
           ("tests/test_contact_outputs_two.py", "tests/test_energy_balance.py")),
    Mutant("compliant shooting: a lower Kelvin-Voigt stop's entry saltation with the upper stop's dashpot",
           "models/core/shooting.py",
           "J[n + i, c] -= (nv[i] if H == 0 else hs.dirn[H, k, i]) * st.cc[k] * hc",
           "J[n + i, c] -= (nv[i] if H == 0 else hs.dirn[H, k, i]) * st.cc[0] * hc",
           ("tests/test_continuation_compliant_two.py",)),
    Mutant("compliant shooting: a Runge-Kutta contact phase's variational equations with the upper stop's "
           "stiffness and damping",
           "models/core/variational.py",
           "fg, fgd, fv = force_partials(code, g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])",
           "fg, fgd, fv = force_partials(code, g, gd, st.kc[0], st.cc[0], st.pe[k], vr[k])",
           ("tests/test_continuation_compliant_two.py",)),
    Mutant("Hunt-Crossley damping chi = 8 (1 - R) / (3 R) instead of / (5 R) (Flores et al. 2011)",
           "models/compliant.py", "return 8.0 * (1.0 - R) / (5.0 * R)",
           "return 8.0 * (1.0 - R) / (3.0 * R)", ("tests/test_compliant.py",)),
    Mutant("Kelvin-Voigt restitution of a damping ratio: the phase of the force-zero exit off by sign",
           "models/compliant.py", "th = math.pi - math.atan2(2.0 * z * s, 1.0 - 2.0 * z * z)",
           "th = math.pi + math.atan2(2.0 * z * s, 1.0 - 2.0 * z * z)", ("tests/test_compliant.py",)),
    # --- saltation matrices
    Mutant("impact saltation: post-impact acceleration without the damping jump (1 + R) m C d U-",
           "models/core/shooting.py", "J[n + i, c] += ((1.0 + Rc) * me * cd[i] + gv * d[i] * an / U) * hc",
           "J[n + i, c] += (Rc * me * cd[i] + gv * d[i] * an / U) * hc", ("tests/test_continuation.py",)),
    Mutant("impact saltation: displacement jump (1 + R) m d U- taken as R m d U-",
           "models/core/shooting.py", "J[i, c] -= (1.0 + Rc) * me * d[i] * hc",
           "J[i, c] -= Rc * me * d[i] * hc", ("tests/test_continuation.py",)),
    Mutant("Kelvin-Voigt entry saltation S = I - d c h_x dropped (the shooting problem's)",
           "models/core/shooting.py",
           "J[n + i, c] -= (nv[i] if H == 0 else hs.dirn[H, k, i]) * st.cc[k] * hc",
           "J[n + i, c] -= 0.0 * hc",
           ("tests/test_continuation_compliant.py",)),
    Mutant("Kelvin-Voigt entry saltation of the beam: the dashpot's jump along (w_1, ..., w_1) instead of w",
           "models/core/shooting.py",
           "J[n + i, c] -= (nv[i] if H == 0 else hs.dirn[H, k, i]) * st.cc[k] * hc",
           "J[n + i, c] -= (nv[0] if H == 0 else hs.dirn[H, k, i]) * st.cc[k] * hc",
           ("tests/test_continuation_compliant.py",)),
    # --- release and grazing
    Mutant("the held contact force's forcing term with the wrong sign (release at the wrong zero)",
           "models/core/stops.py", 'o["lamF"][mask, k] = -sum(', 'o["lamF"][mask, k] = sum(',
           ("tests/test_two_sided.py", "tests/test_event.py")),
    Mutant("release of a held stop at the step start when the force still presses (the release rule)",
           "models/core/contact_policy.py", "return force < 0.0 or (force == 0.0 and dforce < 0.0)",
           "return force <= 0.0", ("tests/test_event.py",)),
    Mutant("grazing: the interpolation bound M2 h^2 / 8 taken ten times too small (missed impacts)",
           "models/core/integrator.py", "return max(g0, g1) + 0.125 * M2 * h * h < 0.0",
           "return max(g0, g1) + 0.0125 * M2 * h * h < 0.0", ("tests/test_hard_cases.py",)),
    Mutant("chatter: accumulation time 2 u / (a (1 + R)) instead of (1 - R) (Budd & Dux 1994)",
           "models/core/contact_policy.py", "D = 2.0 * u / (a * (1.0 - R))", "D = 2.0 * u / (a * (1.0 + R))",
           ("tests/test_event.py",)),
    # --- unit conversions
    Mutant("SI contact force of the SDOF scene: its outputs' force_scale_n 1.4 times too large",
           "models/scene.py", "else mu * m_eff * L / (T * T)", "else 1.4 * mu * m_eff * L / (T * T)",
           ("tests/test_compliant.py",)),
    Mutant("SI contact force of the beam: its scene's mass unit 1.4 kg (force_scale_n 1.4 times too large)",
           "models/builders/matrices.py", "coordinate_scale=float(length_m), mass_unit_kg=1.0,",
           "coordinate_scale=float(length_m), mass_unit_kg=1.4,", ("tests/test_compliant.py",)),
    Mutant("contact duration in s without the 2 pi of omega_n",
           "vibeam/engine/sweep.py", "/ (2 * np.pi * fn)", "/ fn", ("tests/test_compliant.py",)),
    Mutant("energy per impact in J without the length scale (N instead of J)",
           "vibeam/engine/sweep.py", 'data["energy_per_impact" + sfx] * fs * L', 'data["energy_per_impact" + sfx] * fs',
           ("tests/test_compliant.py",)),
    # --- energies
    Mutant("beam Newton energy per impact (1 - R) v^2 / 2 instead of (1 - R^2) v^2 / 2",
           "models/core/event.py", "0.5 * (1.0 - Rk ** 2) * v ** 2, v])", "0.5 * (1.0 - Rk) * v ** 2, v])",
           ("tests/test_energy_balance.py",)),
    Mutant("energy_per_impact: the largest contact loss instead of the mean",
           "vibeam/engine/records.py", "energy_per_impact=float(np.mean(c[:, 3])))",
           "energy_per_impact=float(np.max(c[:, 3])))", ("tests/test_contact_outputs_two.py",)),
    # --- statistics and regression
    Mutant("batch means: standard error std(batch means) / a instead of / sqrt(a)",
           "vibeam/engine/records.py", "return float(np.std(means, ddof=1) / math.sqrt(a)), a - 1",
           "return float(np.std(means, ddof=1) / a), a - 1", ("tests/test_statistics.py",)),
    Mutant("regress excuses every change of period as multistable, not only after a chaotic point",
           "vibeam/analysis/regress.py", "    return after & differ", "    return differ", ("tests/test_statistics.py",)),
    # --- the results writer
    Mutant("the one file writer: a failed write leaves its temporary file behind",
           "vibeam/io/outdir.py", "        try:\n            os.unlink(tmp)\n        except OSError:\n            pass\n",
           "", ("tests/test_faults_data.py",)),
    Mutant("the results store writes a checkpoint over the complete file (results.h5) instead of beside it",
           "vibeam/io/store.py", "out = build_file(self.partial, fill, base,", "out = build_file(self.path, fill, base,",
           ("tests/test_store.py",)),
    Mutant("results writer: the mm datasets of a physical scene in units of 0.1 mm",
           "vibeam/engine/sweep.py", "data[k + \"_mm\"] = data[k] * L * 1e3", "data[k + \"_mm\"] = data[k] * L * 1e4",
           ("tests/test_settle.py",)),
    # --- the platform filter (effects)
    Mutant("platform filter: damping term 1 i zeta r instead of 2 i zeta r",
           "vibeam/engine/effects.py", "return 1.0 / (1.0 - r * r + 2j * zeta_p * r)",
           "return 1.0 / (1.0 - r * r + 1j * zeta_p * r)",
           ("tests/test_effects.py",)),
    # --- the compliant contact phases of the one event integrator and shooting problem (issue 20)
    Mutant("Runge-Kutta contact phase: a Hunt-Crossley stop's force with the first stop's stiffness",
           "models/core/rk.py",
           "f = force(st.law[k], g, gd, st.kc[k], st.cc[k], st.pe[k], vr[k])\n        out[2 * m + k] = f * gd",
           "f = force(st.law[k], g, gd, st.kc[0], st.cc[k], st.pe[k], vr[k])\n        out[2 * m + k] = f * gd",
           ("tests/test_energy_balance.py",)),
    Mutant("compliant shooting: a Hunt-Crossley lower stop's variational equations along the upper stop's "
           "normal +w",
           "models/core/variational.py",
           "w = st.normal[k, j] if H == 0 else hs.pG[H, k, j]\n                dg += w * Y[j, c]",
           "w = st.normal[0, j] if H == 0 else hs.pG[H, k, j]\n                dg += w * Y[j, c]",
           ("tests/test_continuation_hc_beam.py",)),
    # --- the exact recurrence
    Mutant("recurrence: the skip lands one period short of a whole number of cycles",
           "models/core/integrator.py", "                    pp += m * L\n", "                    pp += m * L - 1\n",
           ("tests/test_recurrence.py",)),
    Mutant("recurrence: a skip jumps over the impact and step guards the full run would hit",
           "models/core/integrator.py",
           "ok = m > 0 and ist[_NSTEPS] + m * d_steps <= max_steps and ist[_NIMPT] + m * d_imp <= max_impacts",
           "ok = m > 0",
           ("tests/test_recurrence.py",)),
    Mutant("recurrence: an impact copied into the record keeps its source's period (its time one cycle early)",
           "models/core/integrator.py", "rp = rec.imp_rp[src] + L", "rp = rec.imp_rp[src]",
           ("tests/test_recurrence.py",)),
    Mutant("the verdict's early exit settles a period whose return is within margin x rtol but not rtol",
           "vibeam/engine/records.py", "lo = min(1.0, margin) * rtol", "lo = max(1.0, margin) * rtol",
           ("tests/test_settle.py::test_the_verdicts_early_exit_agrees_with_the_whole_rule",)),
    # --- the dense record (a one-mode record on the transient's grid)
    Mutant("dense record: a sample inside a step read at the next sample's forcing phase",
           "models/core/integrator.py", "sp = tab_r[kd, 0]\n            cp = tab_r[kd, 1]",
           "sp = tab_r[kd + 1, 0]\n            cp = tab_r[kd + 1, 1]",
           ("tests/test_recurrence.py::test_the_dense_record_equals_the_record_on_its_own_grid",)),
    Mutant("dense record: a held step runs to the transient's grid point past the record's samples",
           "models/core/integrator.py", "if j_next < j_end:\n                            cut = min(rem_full",
           "if j_next < 0:\n                            cut = min(rem_full",
           ("tests/test_recurrence.py::test_the_dense_record_equals_the_record_on_its_own_grid",)),
    Mutant("dense record: a step started after an event carries its samples from the grid point's time",
           "models/core/integrator.py", "if from_grid:\n            a11 = P_r[i, 0]", "if True:\n            a11 = P_r[i, 0]",
           ("tests/test_recurrence.py::test_the_dense_record_equals_the_record_on_its_own_grid",)),
    Mutant("the results store never marks a group of another case stale (every unit counted as the file's case)",
           "vibeam/io/store.py", "                if h in same:", "                if True:",
           ("tests/test_store.py",)),
    # --- issue 46: the properties a review found unguarded (independent oracles: tests/test_oracles.py)
    Mutant("a Hertz-family law's case exponent ignored (always 3/2)",
           "models/compliant.py", "return 1.5 if exponent is None else float(exponent)", "return 1.5",
           ("tests/test_oracles.py::test_a_hertz_exponent_of_the_case_is_the_power_of_the_force",)),
    Mutant("a Hertz-family stop's kernel row takes the exponent 3/2 whatever its law's",
           "models/core/stops.py", "pe[i] = float(s.law.exponent)", "pe[i] = 1.5",
           ("tests/test_oracles.py::test_a_hertz_exponent_of_the_case_is_the_power_of_the_force",)),
    Mutant("a 2 x 2 monodromy's Floquet multipliers out of order when its trace is negative",
           "models/core/continuation_kernels.py", "l1 = h + r if h >= 0.0 else h - r", "l1 = h + r",
           ("tests/test_oracles.py::test_floquet_multipliers_of_a_2x2_monodromy_against_lapack",
            "tests/test_oracles.py::test_the_multipliers_of_a_continued_branch_through_its_period_doubling_against_lapack")),
    Mutant("a Lyapunov shot of n periods counted as one period of time",
           "models/orbits/lyapunov.py", "times[k] = n * TWO_PI / float(s.Omega)", "times[k] = TWO_PI / float(s.Omega)",
           ("tests/test_oracles.py::test_lyapunov_exponents_of_period_2_and_3_orbits_are_their_floquet_exponents",)),
    Mutant("vibeam regress passes a periodic point that is NaN on one side only",
           "vibeam/analysis/regress.py", "both_nan = np.isnan(a) & np.isnan(a_ref)",
           "both_nan = np.isnan(a) | np.isnan(a_ref)",
           ("tests/test_oracles.py::test_regress_fails_a_point_that_is_nan_on_one_side_only",)),
    Mutant("the platform filter normalised at f_n instead of its reference frequency",
           "vibeam/engine/effects.py", "H_ref = abs(platform_H(f_ref, fp, zp))",
           "H_ref = abs(platform_H(self.f_n_hz, fp, zp))",
           ("tests/test_oracles.py::test_the_platform_filter_is_normalised_at_its_reference_frequency",)),
    Mutant("the first checkpoint of a --resume starts a fresh file (the stored lines dropped)",
           "vibeam/runner.py", "case.name, text, case_json, start=not resume)", "case.name, text, case_json, start=True)",
           ("tests/test_store.py::test_an_interrupted_resume_keeps_the_stored_lines_byte_for_byte",)),
    Mutant("a beam point stop's static-mode row without its mass normalisation (phi(x) for phi(x) / sqrt(M_S))",
           "models/builders/beam.py", "[float(static_mode_shape(x / L, xm, xs)) / sq]",
           "[float(static_mode_shape(x / L, xm, xs))]",
           ("tests/test_oracles.py::test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration",)),
    Mutant("a beam point stop's gap_mm converted by a static mode normalised at the tip, not the sensor",
           "vibeam/case/beamscene.py",
           "float(static_mode_shape(x / L, g.mass_position_m / L, g.sensor_position_m / L))",
           "float(static_mode_shape(x / L, g.mass_position_m / L, 1.0))",
           ("tests/test_oracles.py::test_a_point_stop_gap_and_first_impact_against_an_own_modal_integration",)),
    Mutant("a beam's gap_lower_mm taken at the contact point (not times phi(x_m))",
           "vibeam/case/beamscene.py", "DCl = lo.gap_mm * 1e-3 * phim", "DCl = lo.gap_mm * 1e-3",
           ("tests/test_oracles.py::test_the_beams_lower_gap_is_converted_to_the_contact_point",)),
    Mutant("the continuation's step grows past ds_max",
           "models/orbits/continuation.py", "ds = min(ds * S.grow, S.ds_max) if pt.its <= S.fast else ds",
           "ds = ds * S.grow if pt.its <= S.fast else ds",
           ("tests/test_oracles.py::test_the_continuation_step_is_capped_at_ds_max",)),
    Mutant("the static mode's K_S integral without its normalisation squared",
           "reductions/static_mode.py", "Ik = x_m**3 / (3 * c**2)", "Ik = x_m**3 / (3 * c)",
           ("tests/test_api.py::test_derive_and_modes_need_no_cli_helper",)),
]


def run(m: Mutant, python: str = sys.executable) -> tuple[str, float]:
    path = ROOT / m.file
    text = path.read_bytes()
    src = text.decode()
    if src.count(m.old) != 1:
        return f"ERROR: the text occurs {src.count(m.old)} times in {m.file}", 0.0
    t0 = time.perf_counter()
    try:
        path.write_bytes(src.replace(m.old, m.new).encode())
        p = subprocess.run([python, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *m.tests],
                           cwd=ROOT, capture_output=True, text=True)
    finally:
        path.write_bytes(text)
    dt = time.perf_counter() - t0
    failed = [ln.split(" ")[1] for ln in p.stdout.splitlines() if ln.startswith("FAILED ")]
    if p.returncode == 1 or (p.returncode == 2 and failed):
        # (2: pytest-xdist ends a -x run that has failed as "Interrupted")
        return "killed by " + (failed[0] if failed else "a failing test"), dt
    if p.returncode == 0:
        return "SURVIVED", dt
    tail = (p.stdout + p.stderr).strip().splitlines()[-1:] or [""]
    return f"ERROR: pytest exit {p.returncode}: {tail[0][:120]}", dt


def main(argv=None) -> int:
    import signal

    # SIGTERM as Ctrl-C, so that the mutated file is restored by run()'s finally
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    argv = sys.argv[1:] if argv is None else argv
    if "--list" in argv:
        for i, m in enumerate(MUTANTS, 1):
            print(f"{i:3d}. {m.what}  [{m.file}]  <- {', '.join(m.tests)}")
        return 0
    pick = [int(a) for a in argv] or range(1, len(MUTANTS) + 1)
    bad = 0
    for i in pick:
        m = MUTANTS[i - 1]
        verdict, dt = run(m)
        bad += not verdict.startswith("killed")
        print(f"{i:3d}. {verdict:<90} {dt:6.1f} s  {m.what}", flush=True)
    print(f"{len(list(pick)) - bad} of {len(list(pick))} mutants killed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
