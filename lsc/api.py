"""``lsc.solve``: one scene in, one :class:`~lsc.result.Result` out."""

from __future__ import annotations

from .model import HybridModel
from .scene import Scene
from . import solvers

__all__ = ["solve", "model_of"]


def solve(scene, method: str | None = None, **options):
    """Simulate one crash.

    Parameters
    ----------
    scene : dict, str, Path or Scene
        The scene (see the scene reference); loaded and validated with :meth:`Scene.load`.
    method : str, optional
        ``"auto"`` (default: the cheapest exact backend), ``"closed-form"``, ``"scipy"``,
        ``"reference"`` (the paper's fixed-step algorithm), ``"exact"``, ``"diffrax"``.
        Overrides the scene's ``[solver] method`` (the scene's solver options that do not apply
        to the method given here are then left out). With ``auto``, options that do not apply to
        the backend it picks (a tolerance, for an exact backend) are left out; a name that no
        backend accepts is a :class:`~lsc.errors.SceneError` with every method.
    **options
        Backend options, overriding the scene's ``[solver]`` table: ``rtol``, ``atol``,
        ``integrator`` (SciPy: ``"DOP853"``, ``"RK45"``, ``"LSODA"``, ``"Radau"``, ...; none
        given: DOP853, or Radau for a stiff damping law, :mod:`lsc.solvers.stiffness`),
        ``dt`` [s] (reference), ``t_end`` [s] (simulate until then; must not cut the crash),
        ``max_events``, ``n_samples`` (points in the sampled series, at most
        :data:`lsc.solvers.MAX_SAMPLES`); ranges in :func:`lsc.solvers.check_option`.

    Returns
    -------
    Result
        Series, events and metrics in the scene's unit system.
    """
    # (a dict's Scene is kept by content, lsc.scene._cache; its model is built anew, cheap on
    # a Scene already loaded, so that nothing a solve computed lazily is shared between solves
    # of dicts)
    model = model_of(scene) if isinstance(scene, Scene) else HybridModel(Scene.load(scene))
    backend, opts = resolve(model.scene, method, options, model=model)
    return solvers.run(model, backend, opts)


def model_of(sc: Scene) -> HybridModel:
    """The :class:`~lsc.model.HybridModel` of loaded scene ``sc``, built once per Scene object
    and kept on it: a Scene is frozen and a model read-only once built, so solving the same
    scene again (another method, other options) builds nothing twice."""
    model = sc.__dict__.get("_model")
    if model is None:
        model = HybridModel(sc)
        object.__setattr__(sc, "_model", model)
    return model


def resolve(sc: Scene, method: str | None, options: dict, *, model=None,
            members: int | None = None) -> tuple[str, dict]:
    """The backend and the validated options a solve of scene ``sc`` uses (see :func:`solve`);
    ``model``: its :class:`~lsc.model.HybridModel` if already built; ``members``: the size of a
    batch of such scenes (``auto`` then prefers batch paths, :func:`lsc.solvers.pick`)."""
    requested = method or sc.solver.method
    for name in options:  # an unknown name is an error whatever the method (auto included)
        if name not in solvers.ALL_OPTIONS:
            solvers.check_option(name, options[name])
    backend = solvers.pick(sc if model is None else model, requested, members)
    accepted = solvers.options_of(backend)
    opts = dict(sc.solver.options)
    if method is not None and method != sc.solver.method:
        # the scene's options were meant for its own method
        opts = {k: v for k, v in opts.items() if k in accepted}
    opts.update({k: v for k, v in options.items() if v is not None or k == "atol"})
    if requested == "auto":
        # auto may pick an exact backend, for which tolerances are moot
        opts = {k: v for k, v in opts.items() if k in accepted}
    for name, value in opts.items():
        solvers.check_option(name, value)
    return backend, opts
