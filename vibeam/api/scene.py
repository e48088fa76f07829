"""A beam scene's own tools, as ``vibeam derive`` and ``vibeam modes``: the SDOF parameters of the
scene by the assumed static mode (:func:`derive`) and its modes (:func:`modes`, with the
``modes.vtu`` and ``modes.png`` files)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vibeam.api.cases import case_and_source
from vibeam.api.common import saved
from vibeam.case.arguments import check_flag, check_path, check_whole
from vibeam.case.beamscene import beam_spec, derive as derive_scene, modes_report, sdof_case_text
from vibeam.errors import CaseError
from vibeam.io.outdir import (OutputLock, check_folder, check_output_file, check_outputs, reading, replace_file,
                              write_text_file)
from vibeam.models.builders.beam_fe import write_modes


@dataclass
class Derived:
    """SDOF parameters of a beam scene by the assumed static mode (:func:`derive`).

    Attributes
    ----------
    case : Case
    rows : list of (name, value, unit, source)
        The table of ``vibeam derive`` (EI, M_S, K_S, f_n, beta_S, ...; SI units).
    reduction, with_beam_mass : vibeam.reductions.static_mode.StaticModeReduction
        The reduction without (the paper's) and with the beam's modal mass.
    scene : vibeam.case.beamscene.BeamScene
    sdof_case_text : str
        The TOML of the SDOF case of the same scene (``vibeam derive --write``).
    """

    case: object
    rows: list
    reduction: object
    with_beam_mass: object
    scene: object
    sdof_case_text: str

    def write(self, path) -> Path:
        """Write :attr:`sdof_case_text` to ``path`` atomically (``--write``)."""
        return write_text_file(Path(path), self.sdof_case_text, "--write")


def derive(case, write=None) -> Derived:
    """SDOF parameters of a beam scene by the assumed static mode (``vibeam derive``; paper
    Eqs. 42-46: ``M_S = m phi(x_m)^2``, ``K_S = EI/L^3 int phi''^2``, ``beta_S = D omega_n / 2``).

    Parameters
    ----------
    case : Case, str, Path or dict
        A beam scene (a fidelity with a finite-element model).
    write : str or Path, optional
        Also write the SDOF case file of the same scene there (``--write``).

    Returns
    -------
    Derived

    Raises
    ------
    vibeam.case.schema.CaseError
        Not a beam scene (one line naming ``model.fidelity``), or a bad case; ``write`` for a beam
        driven by a base acceleration (its :attr:`Derived.sdof_case_text` is empty: the SDOF scene
        takes a base displacement ``gamma V``).
    """
    write = check_path(write, "write")
    c, src = case_and_source(case)
    spec = beam_spec(c, "derive")
    drive = getattr(spec, "drive", None)
    if write is not None and drive is not None:     # the SDOF scene's drive is gamma V (Eq. 43)
        where = f"{src}: " if src else ""
        raise CaseError(f"{where}'model.excitation.kind' = {drive[0]!r}: `vibeam derive --write` writes the SDOF "
                        f"scene of a base displacement (gain and voltage, Eq. 43); allowed: a beam driven by gain "
                        f"and voltage")
    if write is not None:     # before anything is computed: a name that may be written, never the case file
        with reading([(case, "case file")] if isinstance(case, (str, Path)) else []):
            check_output_file(write, "--write")
    d = derive_scene(spec)
    res = Derived(c, d["rows"], d["reduction"], d["with_beam_mass"], d["scene"],
                  "" if drive is not None else sdof_case_text(c, spec, d["reduction"], d["scene"]))
    if write is not None:
        res.write(write)
    return res


@dataclass
class Modes:
    """Modes of a beam scene (:func:`modes`).

    Attributes
    ----------
    case : Case
    fe : vibeam.models.builders.beam_fe.BeamFE
        The finite-element model (``fe.ndof`` degrees of freedom).
    modes, contact : modal data
        Free modes (``frequencies_hz`` (n,), ``shapes`` (ndof, n), ``participation`` (n,),
        kg^0.5, ``effective_mass_kg`` (n,)) and contact modes (beam held at the stop).
    total_mass_kg : float
    sensor_modal_mass_kg : ndarray, shape (n,)
        The modal mass seen at the sensor, ``1 / (s phi_i)^2`` (kg).
    n : int
        Modes asked for.
    paths : dict
        ``vtu`` and ``png`` written (with ``out``).
    """

    case: object
    fe: object
    modes: object
    contact: object
    total_mass_kg: float
    sensor_modal_mass_kg: np.ndarray
    n: int
    report: dict
    paths: dict = field(default_factory=dict)

    def plot(self, path=None):
        """Free and contact mode shapes along the beam, or a continuum's shapes (``modes.png``)."""
        return saved(shapes_figure(self.report, self.case.name), path)


def modes(case, n: int = 6, out=None, plots: bool = True) -> Modes:
    """Natural frequencies, participation, effective masses and contact modes of a beam scene
    (``vibeam modes``; Hermite FE cantilever with point mass and rotary inertia, base excitation).

    Parameters
    ----------
    case : Case, str, Path or dict
        A beam scene.
    n : int
        Number of modes (>= 1; at most the FE model's degrees of freedom).
    out : str or Path, optional
        A folder: ``modes.vtu`` (ParaView) and ``modes.png`` are written there atomically.
    plots : bool
        With ``out``: also ``modes.png`` (``--no-plots``: ``modes.vtu`` only).

    Returns
    -------
    Modes

    Raises
    ------
    vibeam.case.schema.CaseError
        Not a beam scene; the folder in use by another vibeam process.
    TypeError, ValueError
        ``n`` not a whole number >= 1, ``out`` not a path.
    """
    n = check_whole(n, "n", 1, 10 ** 6)
    out = check_path(out, "out")
    check_flag(plots, "plots")
    c, _ = case_and_source(case)
    spec = beam_spec(c, "modes")
    if out is not None:                   # every name written, checked before anything is computed
        check_outputs(out, MODES_FILES if plots else MODES_FILES[:1])
    # a spec with its own report (a continuum's), else the FE beam's
    rep = spec.modes_report(n) if hasattr(spec, "modes_report") else modes_report(spec, n=n)
    res = Modes(c, rep.get("fe"), rep["modes"], rep["contact"], rep["total_mass_kg"], rep["sensor_modal_mass_kg"],
                n, rep)
    if out is not None:
        folder = check_folder(Path(out))
        with OutputLock(folder):          # like every writer: one vibeam process per folder
            res.paths = write_modes_files(res, folder, plots=plots)
    return res


#: the files :func:`write_modes_files` writes
MODES_FILES = ("modes.vtu", "modes.png")


def write_modes_files(res: Modes, folder, plots: bool = True) -> dict:
    """``modes.vtu`` and (``plots``) ``modes.png`` of :func:`modes` into ``folder`` (atomically)."""
    folder = Path(folder)
    rep = res.report
    # a scene's report may carry its own writer (a continuum: its mesh through meshio)
    vtu = replace_file(folder / "modes.vtu", rep.get("write_vtu") or
                       (lambda p: write_modes(p, res.fe, n=min(res.n, len(res.modes.frequencies_hz)))))
    if not plots:
        return {"vtu": vtu}
    from vibeam.plots.sweep import save_close  # lazy: matplotlib.pyplot (0.6 s) out of `vibeam derive`

    png = save_close(shapes_figure(rep, res.case.name), folder / "modes.png")
    return {"vtu": vtu, "png": png}


def shapes_figure(rep: dict, title: str = ""):
    """``modes.png`` of a modes report: :func:`modes_figure` of a beam's, or of a solid's (a report
    with its ``mesh``) :func:`vibeam.plots.modes.continuum_modes_figure`."""
    if rep.get("mesh") is None:
        return modes_figure(rep, title)
    from vibeam.plots.modes import continuum_modes_figure  # lazy: matplotlib (0.6 s) out of `vibeam derive`

    return continuum_modes_figure(rep, title)


def modes_figure(rep: dict, title: str = ""):
    """Free and contact mode shapes along the beam (the first four of each), normalised; a
    Figure (``modes.png`` of ``vibeam modes``).  ``rep``: :func:`vibeam.case.beamscene.modes_report`."""
    fe, md, cm = rep["fe"], rep["modes"], rep["contact"]
    L = fe.geometry.length_m
    x = np.linspace(0, L, 361)
    import matplotlib.pyplot as plt  # lazy: out of `vibeam derive` (0.6 s), which draws no figure

    from vibeam.plots import style  # lazy: matplotlib, with pyplot above

    with style.context():
        fig, axes = plt.subplots(1, 2, figsize=(10, 4.4), sharey=True)
        for ax, m, lab in ((axes[0], md, "free"), (axes[1], cm, "contact (held at the stop)")):
            for i in range(min(4, m.shapes.shape[1])):
                w = fe.deflection(m.shapes[:, i], x)
                ax.plot(x * 1e3, w / np.max(np.abs(w)), label=f"{m.frequencies_hz[i]:.2f} Hz")
            for xp, nm in ((fe.geometry.sensor_position_m, "$L_S$"), (fe.geometry.mass_position_m, "$L_m$")):
                ax.axvline(xp * 1e3, color="0.6", ls=":")
                ax.text(xp * 1e3, 1.02, nm, ha="center", fontsize=8)
            ax.set_title(f"{lab} modes", loc="left")
            ax.set_xlabel(style.label("position along the beam x", "mm"))
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=4, title="mode")
        axes[0].set_ylabel(style.label("normalised deflection", None))
        style.titles(fig, title, "mode shapes of the FE beam")
    return fig
