"""A self-contained HTML report of one simulated crash, to attach to a case file.

:func:`render_report` returns, and :func:`write_report` writes, one HTML file that holds
everything needed to check the numbers in it: the scene as given (the file's text where it was
read from one, and the scene as loaded) with its SHA-256 (:func:`scene_hash`), the method, its
tolerances and what it guarantees (:func:`accuracy_statement`), the versions of ``lsc`` and its
dependencies (:func:`versions`), the summary and impacts tables, warnings, the MER cross-check,
the figures (acceleration with the peaks marked, velocity, IF-D loop) as embedded PNG images,
the Monte Carlo percentiles of the scene's ``[uncertainty]`` table (fixed seed, stated), the
closing-speed bound of each contact with a failure force, and a methods paragraph citing the
model. The file loads nothing: no script, no stylesheet, no font, no image from anywhere else.
"""

from __future__ import annotations

import base64
import dataclasses
import datetime
import hashlib
import io
import os
import platform
from html import escape
from pathlib import Path

import numpy as np

from .errors import SceneError, SimulationError
from .html import _num, _table, result_html, summary_html
from .provenance import (CANONICAL_FORM, _csv_files, _file_sha256, canonical_scene,  # noqa: F401
                         scene_hash, to_toml, versions)
from .scene import METHODS, Damping, Scene

__all__ = ["render_report", "write_report", "scene_hash", "canonical_scene", "accuracy_statement",
           "versions", "to_toml", "CANONICAL_FORM", "MC_SAMPLES", "MC_SEED"]

#: Monte Carlo samples and seed of the uncertainty section (defaults of :func:`render_report`).
MC_SAMPLES = 1000
MC_SEED = 0

_MODEL = "Simulation Model for Low-Speed Bumper-to-Bumper Crashes"


# --------------------------------------------------------------------------- accuracy
def _backend(result) -> tuple[str, dict]:
    """The ``(method, options)`` that solve the result's scene again as the result was solved
    (``result.method`` names the backend, and the integrator after a hyphen)."""
    name = str(result.method)
    method = next((m for m in sorted(METHODS, key=len, reverse=True)
                   if name == m or name.startswith(m + "-")), "auto")
    opts = {k: v for k, v in result.tolerances.items() if v is not None}
    if name.startswith(method + "-"):
        opts["integrator"] = name[len(method) + 1:]
    return method, opts


def accuracy_statement(result) -> str:
    """What the method of ``result`` guarantees about its numbers, in one or two sentences
    (from the backends' documented accuracy)."""
    method, opts = _backend(result)
    tol = result.tolerances
    if method == "closed-form":
        return ("Exact: the closed-form solution of the model (two vehicles, linear loading, "
                "straight unloading line); the numbers are exact up to floating-point rounding.")
    if method == "exact":
        return ("Exact: segment-by-segment closed-form solution of the piecewise-linear IF-D "
                "curves, every mode switch at its exact time; the numbers are exact up to "
                "floating-point rounding.")
    if method in ("scipy", "diffrax"):
        what = "SciPy solve_ivp" if method == "scipy" else "diffrax (JAX, float64)"
        atol = tol.get("atol")
        return (f"To the tolerance asked for: {what} with the {opts.get('integrator', '')} "
                f"integrator, rtol = {_num(tol.get('rtol', float('nan')))}, atol = "
                f"{'rtol × the scene’s scales (default)' if atol is None else _num(atol)}; "
                "the numbers are as accurate as that tolerance (about rtol relative), and every "
                "event (mode switch) is located on the integrator's dense output to the same "
                "accuracy. Quote them only to the digits that rtol supports.")
    if method == "reference":
        dt = tol.get("dt", float("nan"))
        return (f"First order in the time step: the paper's fixed-step algorithm (Eqs. 1–8) with "
                f"dt = {_num(dt)} {result.units.get('t', 's')}; a mode switch happens at the next "
                "time step, not at its exact time. Its error is proportional to dt (about 1e-4 "
                "relative in ΔV at dt = 1e-5 s on the paper's scene; it halves when dt halves). "
                "Quote its numbers only to the digits that dt supports.")
    return f"Method {result.method}: see the documentation's backends page for its accuracy."


# --------------------------------------------------------------------------- figures
def _png(draw, figsize=(7.0, 4.5), dpi: int = 110) -> str:
    """An ``<img>`` with the figure ``draw(ax)`` draws, as an embedded PNG (data URI)."""
    from matplotlib.figure import Figure  # no pyplot: nothing is shown or kept
    fig = Figure(figsize=figsize, layout="constrained")
    draw(fig.add_subplot())
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    w, h = (round(x * dpi) for x in figsize)
    return f'<img alt="" width="{w}" height="{h}" src="data:image/png;base64,{data}">'


def _mark_peaks(result, ax) -> None:
    """Mark each vehicle's peak acceleration (the reported one) on an acceleration plot in g."""
    a = np.asarray(result.a)
    g = float(result.scene.g)
    for i, veh in enumerate(result.scene.vehicles):
        peak = float(result.peak_acceleration[i])
        j = int(np.argmin(np.abs(a[:, i] - peak)))
        ax.plot(result.t[j], peak / g, ls="none", marker="o", ms=7, mfc="none",
                color=f"C{i % 10}", zorder=4)
        ax.annotate(f"{veh.name}: {peak / g:+.4g} g\n({peak:+.5g} {result.units['a']})",
                    (result.t[j], peak / g), xytext=(10, 0), textcoords="offset points",
                    va="center", fontsize=8, color=f"C{i % 10}",
                    bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none", "alpha": 0.8})


def _figures(result) -> list[tuple[str, str]]:
    """``(caption, <img>)`` of the acceleration (peaks marked), velocity and IF-D figures."""
    from . import plots

    def accel(ax):
        plots.acceleration(result, ax=ax)
        _mark_peaks(result, ax)

    return [("Acceleration of each vehicle against time, the reported peaks marked "
             "(left axis in g, right axis in the scene's unit; events as vertical lines).",
             _png(accel)),
            ("Velocity of each vehicle against time.",
             _png(lambda ax: plots.velocity(result, ax=ax))),
            ("Contact force against deformation (the IF-D loop): loading solid, unloading dashed.",
             _png(lambda ax: plots.ifd_loop(result, ax=ax), figsize=(6.5, 4.5)))]


# --------------------------------------------------------------------------- sections
def _section(title: str, *parts: str, anchor: str = "") -> str:
    ident = f' id="{anchor}"' if anchor else ""
    return f"<section{ident}><h2>{escape(title)}</h2>{''.join(parts)}</section>"


def _pre(text: str) -> str:
    return f"<pre>{escape(text)}</pre>"


def _scene_section(scene: Scene, file: Path | None, raw: bytes | None) -> str:
    u = scene.units
    parts = [f"<p>Name: <b>{escape(scene.name)}</b>. Unit system: <b>{escape(u)}</b> (a bare "
             f"number is in {escape(', '.join(scene.unit(k) for k in ('length', 'time', 'mass', 'force')))}"
             f"; a quantity written with its unit is converted). g = {_num(scene.g)} "
             f"{escape(scene.unit('acceleration'))}.</p>",
             f"<p>SHA-256 of the scene: <code class=\"hash\">{scene_hash(scene)}</code><br>"
             f"<small>hashed: {escape(CANONICAL_FORM)}; reproduce it with "
             "<code>lsc.report.scene_hash(scene)</code>.</small></p>"]
    if file is not None:
        text = raw.decode("utf-8-sig", errors="replace")
        parts.append(f"<p>Read from the file <code>{escape(str(file))}</code>, SHA-256 of its "
                     f"bytes (as <code>sha256sum</code> prints it): <code class=\"hash\">"
                     f"{hashlib.sha256(raw).hexdigest()}</code>. Its text:</p>{_pre(text)}")
    csvs = _csv_files(scene)
    if csvs:
        rows = [[escape(where), f"<code>{escape(str(f))}</code>",
                 f"<code>{_file_sha256(f)}</code>" if f.is_file() else "not readable now"]
                for where, f in csvs]
        parts.append(_table("CSV files the scene reads (part of the scene: attach them)",
                            ["scene key", "file", "SHA-256"], rows))
    parts.append(f"<details{'' if file is not None else ' open'}><summary>The scene as loaded "
                 "(the hashed content), written as TOML</summary>"
                 f"{_pre(to_toml(scene.source))}</details>")
    rows = [[escape(v.name), _num(v.mass), _num(v.mass * scene.g), _num(v.speed),
             "—" if v.brake is None else f"μ {_num(v.brake.mu)}, μ<sub>s</sub> "
                                         f"{_num(v.brake.mu_static)}"]
            for v in scene.vehicles]
    parts.append(_table("vehicles as interpreted (rear to front)",
                        ["vehicle", f"mass<br><small>{escape(scene.unit('mass'))}</small>",
                         f"weight<br><small>{escape(scene.unit('force'))}</small>",
                         f"speed<br><small>{escape(scene.unit('velocity'))}</small>", "brake"],
                        rows))
    return _section("Scene", *parts, anchor="scene")


def _method_section(result) -> str:
    tol = ", ".join(f"{escape(str(k))} = {'default' if v is None else escape(str(v))}"
                    for k, v in result.tolerances.items())
    stats = ", ".join(f"{escape(str(k))} {escape(_num(v) if isinstance(v, float) else str(v))}"
                      for k, v in result.stats.items() if k != "warnings")
    return _section(
        "Method and accuracy",
        f"<p>Method: <b>{escape(str(result.method))}</b>"
        f"{f' (asked for: {escape(result.scene.solver.method)} in the scene)' if result.scene.solver.method != result.method else ''}"
        f". Tolerances: {tol or 'none (an exact method)'}.</p>",
        f"<p><b>Accuracy:</b> {escape(accuracy_statement(result))}</p>",
        f"<p><small>Solver statistics: {stats}.</small></p>", anchor="method")


def _versions_section(result) -> str:
    rows = [[escape(k), escape(v)] for k, v in versions(str(result.method)).items()]
    rows.append(["platform", escape(platform.platform())])
    return _section("Software", _table("versions", ["package", "version"], rows),
                    anchor="versions")


def _warnings(result) -> list[str]:
    w = getattr(result, "warnings", None)
    if w is None:
        w = result.stats.get("warnings", ())
    return [str(x) for x in w]


def _warnings_section(result, notes: list[str]) -> str:
    items = _warnings(result) + notes
    if not items:
        return _section("Warnings", "<p>None: the solver reported no accuracy warning.</p>",
                        anchor="warnings")
    lis = "".join(f"<li>{escape(x)}</li>" for x in items)
    return _section("Warnings", f'<ul class="warn">{lis}</ul>', anchor="warnings")


def _cell(value) -> str:
    if value is None:
        return "—"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return _num(value)
    if isinstance(value, (tuple, list, np.ndarray)):
        return ", ".join(_cell(v) for v in value)
    return escape(str(value))


#: Unit kinds of impact fields whose names are not metric names of :attr:`lsc.Result.units`.
_IMPACT_KINDS = {"t_start": "time", "t_end": "time", "duration": "time",
                 "closing_speed": "velocity", "separation_speed": "velocity",
                 "v_start": "velocity", "v_end": "velocity", "peak_acceleration_g": "g"}


def _impacts_section(result) -> str:
    impacts = getattr(result, "impacts", None)
    if not impacts:
        return ""
    fields = [f.name for f in dataclasses.fields(impacts[0])]

    def unit(name):
        kind = _IMPACT_KINDS.get(name)
        if kind == "g":
            return "g"
        return result.scene.unit(kind) if kind else result.units.get(name, "")

    rows = [[escape(n) + (f" <small>[{escape(unit(n))}]</small>" if unit(n) else "")]
            + [_cell(getattr(m, n)) for m in impacts] for n in fields]
    header = ["field"] + [f"impact {j}" for j in range(1, len(impacts) + 1)]
    return _section("Impacts", '<div class="wide">'
                    + _table("each touch → separation episode, one per column (pairs: rear, "
                             "front vehicle)", header, rows) + "</div>", anchor="impacts")


def _mer_section(result) -> str:
    from .analysis.mer import format_mer
    if result.scene.n_vehicles != 2:
        return _section("MER cross-check", "<p>Not applicable: MER applies to two vehicles, "
                        f"the scene has {result.scene.n_vehicles}.</p>", anchor="mer")
    text = format_mer(result)
    text = text if isinstance(text, str) else "\n".join(text)
    return _section("MER cross-check", "<p>The Momentum–Energy–Restitution ΔVs, from momentum "
                    "conservation and the restitution, beside the simulated ones:</p>",
                    _pre(text), anchor="mer")


def _uncertainty_section(result, method, opts, n, seed, notes) -> str:
    dists = result.scene.source.get("uncertainty")
    if not dists:
        return ""
    from .analysis.uncertainty import monte_carlo
    try:
        mc = monte_carlo(result.scene, dists, n, seed=seed, method=method, progress=False, **opts)
    except SimulationError as e:
        notes.append(f"uncertainty: not computed: {e}")
        return _section("Uncertainty", f"<p>Not computed: {escape(str(e))}</p>",
                        anchor="uncertainty")
    front = result.scene.n_vehicles - 1
    return _section(
        "Uncertainty",
        f"<p>Monte Carlo over the scene's <code>[uncertainty]</code> table: {n} samples drawn "
        f"with seed {escape(str(seed))} (numpy PCG64; the same seed gives the same samples), "
        f"each solved by {escape(mc.sweep.method)}. Percentiles over the solved members:</p>",
        summary_html(mc),
        _png(lambda ax: mc.histogram("delta_v", front, ax=ax), figsize=(6.0, 4.0)),
        anchor="uncertainty")


def _bound_section(result, method, opts, notes) -> str:
    from .analysis.bounds import max_closing_speed
    parts = []
    for k, c in enumerate(result.scene.contacts):
        if c.failure is None:
            continue
        try:
            b = max_closing_speed(result.scene, contact=k, method=method, **opts)
        except SimulationError as e:
            notes.append(f"bound, contact {k}: not computed: {e}")
            parts.append(f"<p>Contact {k}: not computed: {escape(str(e))}</p>")
            continue
        parts.append(summary_html(b))
    if not parts:
        return ""
    return _section("Closing-speed bound from the failure force",
                    "<p>The speed at which the simulated peak contact force reaches the "
                    "contact's failure force, and the whole-unit rows up to the conservative "
                    "bound (the paper's Table 3 technique):</p>", *parts, anchor="bound")


def _extensions(scene: Scene) -> list[str]:
    """The parts of the scene that go beyond the paper's model (to be named as such)."""
    out = []
    laws = sorted({c.law.law for c in scene.contacts if isinstance(c.law, Damping)})
    out += [f"the {law} damping contact law" for law in laws]
    if any(v.brake is not None for v in scene.vehicles):
        out.append("tyre braking (Coulomb friction)")
    if any(c.failure is not None for c in scene.contacts):
        out.append("bumper failure")
    if scene.n_vehicles > 2:
        out.append(f"a chain of {scene.n_vehicles} vehicles")
    if any(c.gap > 0 for c in scene.contacts):
        out.append("initial gaps between vehicles")
    return out


def _methods_section(result) -> str:
    from . import __version__
    ext = _extensions(result.scene)
    extra = (" This scene also uses extensions of that model, implemented in lsc: "
             + "; ".join(ext) + ".") if ext else ""
    return _section(
        "Methods",
        f"<p>The crash was simulated with lsc {escape(__version__)}, which implements the model "
        f"of the SAE technical paper <i>{_MODEL}</i> (SAE International): each vehicle is a "
        "rigid mass; the bumpers' combined Impact Force–Deformation (IF-D) curve loads until "
        "the vehicles reach a common velocity, then unloads along a branch that returns the "
        "fraction e² of the absorbed energy (e, the coefficient of restitution; Eqs. 9–11 and "
        "Appendix A of the paper), until the contact force is zero and the vehicles separate. "
        "lsc solves the model as a hybrid ordinary differential equation whose events are the "
        "mode switches, with the method and accuracy stated above; the paper's fixed-step "
        f"algorithm is kept as its reference.{escape(extra)}</p>"
        "<p>Cite: <i>lsc: low-speed collinear bumper-to-bumper crash simulation</i>, version "
        f"{escape(__version__)}; and <i>{_MODEL}</i>, SAE technical paper, SAE International.</p>",
        anchor="methods")


# --------------------------------------------------------------------------- the page
_CSS = """
body{font-family:sans-serif;max-width:1100px;margin:1.5em auto;padding:0 1em;color:#111;
line-height:1.4}
h1{font-size:1.5em;margin-bottom:0.2em}h2{font-size:1.2em;border-bottom:1px solid #999;
margin-top:1.6em}
pre{background:#f4f4f4;padding:0.6em;overflow-x:auto;font-size:0.85em}
code.hash{word-break:break-all}
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{font-size:0.9em;color:#333}
ul.warn li{color:#8a1f11;font-weight:bold}
table{border-collapse:collapse;font-size:0.9em}
th,td{border-bottom:1px solid #ddd;padding:0.15em 0.7em;vertical-align:bottom}
caption{text-align:left;font-weight:bold}
.lsc-html,.wide{overflow-x:auto}.wide td{text-align:right}.wide td:first-child{text-align:left}
@media print{section{break-inside:avoid-page}}
"""


def _solve(scene_or_result, solve_options: dict):
    """``(result, file, raw)``: the result, and the scene file (and its bytes) if one was given."""
    from .api import solve
    from .result import Result
    if isinstance(scene_or_result, Result):
        if solve_options:
            raise SceneError(next(iter(solve_options)), "a Result is solved already: solver "
                             "options apply to a scene, not to a Result")
        return scene_or_result, None, None
    file = raw = None
    if isinstance(scene_or_result, (str, os.PathLike)):
        file = Path(scene_or_result).expanduser()
        scene = Scene.load(file)  # says what is wrong with it
        raw = file.read_bytes()
    else:
        scene = Scene.load(scene_or_result)
    return solve(scene, **solve_options), file, raw


def render_report(scene_or_result, *, mc_samples: int = MC_SAMPLES, seed=MC_SEED,
                  **solve_options) -> str:
    """The report of one crash as a self-contained HTML page (a string).

    Parameters
    ----------
    scene_or_result : Result, Scene, dict or path
        A solved :class:`lsc.Result`, or a scene to solve (with a TOML path the file's text and
        its SHA-256 are in the report too).
    mc_samples, seed : int
        Monte Carlo samples and seed for the scene's ``[uncertainty]`` table, if it has one.
    **solve_options
        ``method``, ``rtol``, ``dt``, ... as for :func:`lsc.solve` (a scene only). The
        uncertainty and bound sections solve with the same backend and options as the result.
    """
    result, file, raw = _solve(scene_or_result, solve_options)
    method, opts = _backend(result)
    notes: list[str] = []
    body = [_scene_section(result.scene, file, raw), _method_section(result),
            _section("Summary", result_html(result), anchor="summary"),
            _impacts_section(result), _mer_section(result),
            _section("Figures", *(f"<figure>{img}<figcaption>{escape(cap)}</figcaption></figure>"
                                  for cap, img in _figures(result)), anchor="figures"),
            _uncertainty_section(result, method, opts, mc_samples, seed, notes),
            _bound_section(result, method, opts, notes),
            _methods_section(result), _versions_section(result)]
    from . import __version__
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    title = f"lsc report: {result.scene.name}"
    head = (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
            f"<title>{escape(title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{escape(title)}</h1><p>Made by lsc {escape(__version__)} on {now}.</p>")
    # the warnings go first: a reader must not miss them
    return head + _warnings_section(result, notes) + "".join(body) + "</body></html>\n"


def write_report(scene_or_result, path, overwrite: bool = False, *, mc_samples: int = MC_SAMPLES,
                 seed=MC_SEED, **solve_options) -> Path:
    """Write :func:`render_report` to ``path`` (UTF-8) and return it. Refuses to replace an
    existing file (:class:`lsc.outputs.OutputExistsError`, checked before the solve) unless
    ``overwrite``; the file appears whole or not at all."""
    from .outputs import refuse_existing, write_files
    path = Path(path)
    refuse_existing([path], overwrite)
    page = render_report(scene_or_result, mc_samples=mc_samples, seed=seed, **solve_options)
    write_files({path: lambda tmp: Path(tmp).write_text(page, encoding="utf-8")},
                overwrite=overwrite)
    return path
