"""The exact-chain batch (``lsc.solvers.exact_chain.solve_batch``): many chains of one shape at
once, member by member the single exact-chain solve's numbers (every metric to 1e-12 of its
scale) and its failure message; momentum per member; the elastic chain with a gap passes the
speed down the line exactly; ``lsc.sweep`` with ``method="exact-chain"`` goes through it.
"""

from __future__ import annotations

import numpy as np
import pytest

import lsc
from lsc.locking import WATCH_RESTITUTION
from lsc.model import HybridModel
from lsc.result import METRICS
from lsc.solvers import exact_chain
from lsc.solvers.exact_chain import _batch

from helpers import HARD
from test_exact_chain_locks import TOUCHING_FIVE, _far_push

#: Random members per chain length (3, 4, 5 vehicles) in the default run and with --hard.
MEMBERS = 40 if HARD else 10
#: The scale a metric is compared on, where not its own: a permanent set that is zero (e = 1)
#: is zero to the rounding of the largest deformation it is computed from.
SCALE_OF = {"permanent_deformation": "max_deformation"}


def rounding(r) -> dict:
    """What the rounding of the positions leaves in the deformations (per contact) and what
    follows from them: both solves work in absolute deformations, ``D = x_k - x_{k+1} - gap``,
    so after a long run (a second impact seconds later, 100 ft on) ``D`` is known to the ulps
    of the positions, not of itself."""
    x_max = float(np.max(np.abs(r.scene.speeds))) * max(e.time for e in r.events)
    d = 64 * np.finfo(float).eps * x_max
    energy = d * np.asarray(r.peak_force, float)
    with np.errstate(all="ignore"):
        e_rel = np.nan_to_num(energy / np.asarray(r.energy_absorbed, float))
        f_rel = np.nan_to_num(d / np.asarray(r.max_deformation, float), posinf=0.0)
    a = float(np.max(f_rel)) * np.abs(np.asarray(r.peak_acceleration, float))
    return {"max_deformation": d, "permanent_deformation": d, "energy_absorbed": energy,
            "energy_returned": energy, "restitution_energy": e_rel,
            "peak_force": f_rel * np.asarray(r.peak_force, float), "peak_acceleration": a,
            "peak_acceleration_g": a / r.scene.g}


def random_chains(N: int, n: int, seed: int, e_min: float = 0.0):
    """A US chain of ``N`` vehicles and ``n`` random members swept over it: masses 50 to 1000
    lb (1:20), stiffnesses 1e3 to 1e7 lbf/ft, restitutions in [e_min, 1] (a fifth elastic),
    gaps of 1e-3 to 1 ft or none, closing speeds 0.1 to 30 ft/s or none, the front vehicle at
    rest or moving."""
    rng = np.random.default_rng(seed)
    base = {"units": "US",
            "vehicles": [{"mass": 100.0, "speed": 10.0 if i == 0 else 0.0} for i in range(N)],
            "contacts": [{"loading": {"stiffness": 1e4}, "unloading": {"restitution": 0.5},
                          "gap": 0.1} for _ in range(N - 1)]}
    closing = np.where(rng.random((n, N - 1)) < 0.3, 0.0, 10 ** rng.uniform(-1, 1.5, (n, N - 1)))
    v = np.empty((n, N))
    v[:, -1] = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(-10, 20, n))
    for i in range(N - 2, -1, -1):
        v[:, i] = v[:, i + 1] + closing[:, i]
    v[:, 0] += np.where(v[:, 0] == v[:, -1], 10.0, 0.0)
    values = {}
    for i in range(N):
        values[f"vehicles.{i}.mass"] = 10 ** rng.uniform(np.log10(50.0), 3.0, n)
        values[f"vehicles.{i}.speed"] = v[:, i]
    for k in range(N - 1):
        values[f"contacts.{k}.loading.stiffness"] = 10 ** rng.uniform(3, 7, n)
        values[f"contacts.{k}.unloading.restitution"] = np.where(
            rng.random(n) < 0.2, 1.0, rng.uniform(e_min, 1.0, n))
        values[f"contacts.{k}.gap"] = np.where(rng.random(n) < 0.4, 0.0,
                                               10 ** rng.uniform(-3, 0, n))
    return lsc.load_scene(base), values


def _member(scene, values, j):
    return scene.with_values({path: float(v[j]) for path, v in values.items()})


def _single(scene, values, j, **options):
    """Member ``j`` solved alone: its Result, or the status the batch must give it."""
    try:
        return exact_chain.solve(HybridModel(_member(scene, values, j)), n_samples=2, **options)
    except lsc.SimulationError as err:
        return f"SimulationError: {err}"


def _rounding_response(scene, values, j, name) -> np.ndarray:
    """How far the single solve's metric ``name`` of member ``j`` moves (per element) under a
    relative change of 1e-14 in its data: the larger of what moving the rear car's speed does
    and what moving every swept mass, alternately up and down, does (a contact whose first
    impact is over before the rear car reaches it does not feel its speed): the member's own
    amplification of rounding."""
    member = {path: float(v[j]) for path, v in values.items()}
    masses = {p: x * (1 + (-1) ** i * 1e-14) for i, (p, x) in
              enumerate((p, x) for p, x in member.items() if p.endswith(".mass"))}
    probes = [{**member, "vehicles.0.speed": member["vehicles.0.speed"] * (1 + 1e-14)},
              {**member, **masses}]
    r = exact_chain.solve(HybridModel(scene.with_values(member)), n_samples=2)
    want = np.asarray(getattr(r, name), float)
    return np.max([np.abs(np.asarray(getattr(exact_chain.solve(
        HybridModel(scene.with_values(m)), n_samples=2), name), float) - want) for m in probes],
        axis=0)


def _differing(scene, values, out, rtol: float = 1e-12) -> list:
    """The members whose batch metrics differ from the single solve's by more than ``rtol`` of
    their scale (and the rounding of the positions) and by more than what a relative change
    of 1e-12 in the data does to the single solve (100 times its response to 1e-14 of the
    rear car's speed or of the masses, :func:`_rounding_response`); a failing member must
    have the single solve's message. Both solves are exact to rounding, but not to the same
    rounding (the modes of stacked matrices, sums in another order, the stops of the root
    refinements): an ill-conditioned chain (light cars ringing between stiff contacts, tens
    of events) amplifies those ulps up to 1e7 times. Measured on 400 random 4-car chains: 37
    members beyond 1e-12 (v_final up to 2.8e-7 of its scale), each within 80 times its
    response to 1e-14 of the rear car's speed, most within 4 times."""
    differ = []
    for j in range(len(out["status"])):
        r = _single(scene, values, j)
        if isinstance(r, str):
            assert out["status"][j] == r
            continue
        assert out["status"][j] == "ok"
        for name in METRICS:
            want, got = np.asarray(getattr(r, name), float), out["metrics"][name][j]
            assert np.array_equal(np.isnan(want), np.isnan(got)), (j, name, want, got)
            if np.all(np.isnan(want)):
                continue
            scale = np.nanmax(np.abs(getattr(r, SCALE_OF.get(name, name))))
            tol = rtol * scale + rounding(r).get(name, 0.0)
            if np.all((np.abs(got - want) <= tol) | np.isnan(want)):
                continue
            tol = tol + 100 * _rounding_response(scene, values, j, name)
            if not np.all((np.abs(got - want) <= tol) | np.isnan(want)):
                differ.append((j, name, want, got))
    return differ


@pytest.mark.parametrize("N, seed", [(3, 1), (4, 2), (5, 3)])
def test_batch_is_the_single_solve_member_by_member(N, seed):
    scene, values = random_chains(N, MEMBERS, seed, e_min=0.05)
    assert _differing(scene, values, exact_chain.solve_batch(HybridModel(scene), values)) == []


def test_an_ill_conditioned_member_agrees_to_its_rounding_response():
    """Light middle cars (56 and 68 lb) between stiff contacts, 79 events: the batch's and the
    single solve's final speeds part by about 2e-7 ft/s, far beyond 1e-12 of the speeds, while
    a relative change of 1e-14 in the rear car's speed moves the single solve's by as much: the
    chain amplifies rounding some 1e7 times, and the two agree to what a change of 1e-12 in
    the data does."""
    scene, values = random_chains(4, 400, 2, e_min=0.05)
    one = {path: v[106:107] for path, v in values.items()}
    out = exact_chain.solve_batch(HybridModel(scene), one)
    r = _single(scene, one, 0)
    dv = np.max(np.abs(out["metrics"]["v_final"][0] - r.v_final))
    scale = np.max(np.abs(r.v_final))
    assert len(r.events) > 50 and dv > 1e-10 * scale
    assert dv <= 1e-12 * scale + 100 * np.max(_rounding_response(scene, one, 0, "v_final"))


def test_unloading_by_stiffness_is_the_single_solve_member_by_member():
    _, values = random_chains(3, 8, 17, e_min=0.05)
    rng = np.random.default_rng(17)
    for k in range(2):
        del values[f"contacts.{k}.unloading.restitution"]
        values[f"contacts.{k}.unloading.stiffness"] = (values[f"contacts.{k}.loading.stiffness"]
                                                       * 10 ** rng.uniform(0, 2, 8))
    scene = lsc.load_scene({
        "units": "US", "vehicles": [{"mass": 100.0, "speed": 10.0 if i == 0 else 0.0}
                                    for i in range(3)],
        "contacts": [{"loading": {"stiffness": 1e4}, "unloading": {"stiffness": 1e5},
                      "gap": 0.1}] * 2})
    assert _differing(scene, values, exact_chain.solve_batch(HybridModel(scene), values)) == []


def test_the_vectorised_path_solves_most_members_itself(monkeypatch):
    """Members are handed to the single solve only where the vectorised search cannot decide
    (or contacts chatter): on random 3-car chains, a small minority."""
    alone = []
    original = _batch.solve_alone
    monkeypatch.setattr(_batch, "solve_alone",
                        lambda solve, model, values, members, *a, **kw:
                        alone.extend(members) or original(solve, model, values, members, *a, **kw))
    scene, values = random_chains(3, 60, 7, e_min=0.05)
    out = exact_chain.solve_batch(HybridModel(scene), values)
    assert len(alone) <= 6, alone
    assert np.all(out["status"] == "ok")


def test_a_failing_member_has_the_single_solves_message():
    scene, values = random_chains(3, 8, 11, e_min=0.05)
    out = exact_chain.solve_batch(HybridModel(scene), values, max_events=4)
    failed = 0
    for j in range(8):
        r = _single(scene, values, j, max_events=4)
        if isinstance(r, str):
            failed += 1
            assert out["status"][j] == r
            assert r.startswith("SimulationError: event limit reached (4 events by t = ")
            assert all(np.all(np.isnan(out["metrics"][name][j])) for name in METRICS)
        else:
            assert out["status"][j] == "ok"
            assert out["metrics"]["duration"][j] == pytest.approx(r.duration, rel=1e-12)
    assert failed >= 2   # (the case the test is about does occur)


def test_momentum_is_conserved_member_by_member():
    scene, values = random_chains(4, 16, 5)
    out = exact_chain.solve_batch(HybridModel(scene), values)
    ok = out["status"] == "ok"
    m = np.stack([values[f"vehicles.{i}.mass"] for i in range(4)], axis=1)
    v0 = np.stack([values[f"vehicles.{i}.speed"] for i in range(4)], axis=1)
    p0 = np.sum(m * v0, axis=1)
    p1 = np.sum(m * out["metrics"]["v_final"], axis=1)
    scale = np.sum(m * np.abs(v0), axis=1)
    assert ok.sum() >= 12
    assert np.max(np.abs(p1 - p0)[ok] / scale[ok]) <= 1e-14


def test_elastic_chain_with_a_gap_passes_the_speed_down_the_line():
    """Three equal cars, e = 1, the front car 2 ft ahead of the middle one: the first
    collision passes v0 to the middle car, which passes it to the front car: (0, 0, v0) (the
    first impact is over before the middle car has crossed the gap)."""
    scene = lsc.load_scene({
        "units": "US", "vehicles": [{"weight": 3000, "speed": 10}, {"weight": 3000, "speed": 0},
                                    {"weight": 3000, "speed": 0}],
        "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 1.0}},
                     {"loading": {"stiffness": 1e5}, "unloading": {"restitution": 1.0},
                      "gap": 2.0}]})
    v0 = np.array([1.0, 5.0, 10.0, 20.0])
    out = exact_chain.solve_batch(HybridModel(scene), {"vehicles.0.speed": v0})
    assert np.all(out["status"] == "ok")
    want = np.stack([0 * v0, 0 * v0, v0], axis=1)
    assert np.max(np.abs(out["metrics"]["v_final"] - want) / v0[:, None]) <= 1e-12


def test_sweep_goes_through_the_batch(monkeypatch):
    calls, advanced = [], []
    original = _batch.solve_batch

    def spy(model, values, *, progress=None, **options):
        calls.append(len(next(iter(values.values()))))
        return original(model, values, progress=lambda k: advanced.append(k) or
                        (progress(k) if progress else None), **options)

    monkeypatch.setattr(_batch, "solve_batch", spy)
    scene, values = random_chains(3, 12, 13, e_min=0.05)
    res = lsc.sweep(scene, values, method="exact-chain", progress=False)
    assert calls == [12] and sum(advanced) == 12
    assert np.all(res.status == "ok")
    for j in (0, 5, 11):
        r = exact_chain.solve(HybridModel(_member(scene, values, j)), n_samples=2)
        assert res.metrics["delta_v"][j] == pytest.approx(r.delta_v, rel=1e-12, abs=1e-12)


def test_peaks_taken_at_the_ends_where_no_function_turns():
    """A segment's peaks are searched only where a force or a middle vehicle's acceleration may
    turn inside it (a contact unloading, or loaded on both sides of the vehicle) and may change
    the first-impact record (a force on an unloading line stays below its top, F_max, which
    the record holds; a middle vehicle's acceleration below the larger of its forces' bounds
    over its mass); elsewhere the ends give them. On random 3- and 4-car chains, segment by
    segment, every value that exceeds what the record holds is the one that the search of every
    loaded contact's force finds (to rounding), and every other one stays below the record;
    the ends are taken for many segments and many functions are left to the record; and every
    member's peak force and acceleration is the single solve's."""
    original = _batch._Batch._peaks
    taken, kept = [], []

    def peaks(self, motion, slope, force, ix, r, tau, monotone, unloads, top_force, bars):
        got, unsure = original(self, motion, slope, force, ix, r, tau, monotone, unloads,
                               top_force, bars)
        none = np.zeros_like(monotone)
        want, unsure_all = original(self, motion, slope, force, ix, r, tau, none, none,
                                    top_force, np.full(bars.shape, -np.inf))
        ok = (~unsure & ~unsure_all)[:, None]
        scale = np.max(np.abs(want), axis=1, keepdims=True)
        # (what each peak must exceed to enter the record: an end vehicle's, its force's
        # over its mass)
        K, m = self.K, self.m[ix[r]]
        bar = np.concatenate([bars[:, :K], bars[:, :1] / m[:, :1], bars[:, K:],
                              bars[:, K - 1:K] / m[:, -1:]], axis=1)
        size = np.abs(want)
        size[:, :K] = want[:, :K]
        matters = size > bar
        close = np.abs(got - want) <= 1e-13 * np.broadcast_to(scale, got.shape)
        assert np.all(close[ok & matters])
        value = np.abs(got)
        value[:, :K] = got[:, :K]
        below = value <= bar + 1e-13 * np.broadcast_to(scale, got.shape)
        assert np.all(below[ok & ~matters])
        taken.append(int(np.sum(monotone.any(axis=1))))
        kept.append(int(np.sum(~matters & np.isfinite(bar))))
        return got, unsure

    for N, seed in ((3, 23), (4, 29)):
        scene, values = random_chains(N, 40, seed, e_min=0.05)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(_batch._Batch, "_peaks", peaks)
            out = exact_chain.solve_batch(HybridModel(scene), values)
        for j in range(0, 40, 4):
            r = _single(scene, values, j)
            for name in ("peak_force", "peak_acceleration"):
                want, got = np.asarray(getattr(r, name), float), out["metrics"][name][j]
                tol = 1e-12 * np.max(np.abs(want)) + rounding(r)[name]
                assert np.all(np.abs(got - want) <= tol), (j, name, want, got)
    assert sum(taken) > 100 and sum(kept) > 100


@pytest.mark.parametrize("w", [1e-3, 1.0, 37.0, 2.5e3, 1e5])
def test_the_sampled_basis_is_the_sine_and_cosine_to_a_few_ulps(w):
    """``S = sin ωτ/ω`` and ``C = (1 - cos ωτ)/ω²`` from one tangent of the half angle
    (:func:`_batch_modes.half_angle`), against mpmath, from τ = 0 through the half periods
    (where the tangent is infinite, or nearly) to 1e4 radians."""
    import mpmath
    from lsc.solvers.exact_chain._batch_modes import basis
    angles = np.concatenate([[0.0, 1e-300, 1e-12, 1e-6, 0.5], np.pi * np.arange(1, 8),
                             np.nextafter(np.pi * 3, 0.0) + 0.0 * np.arange(1),
                             np.geomspace(1.0, 1e4, 40)])
    tau = angles / w
    S, C = basis(np.array([[0.0, w]]), tau[None, :])
    mpmath.mp.prec = 120
    for t, s, c in zip(tau.tolist(), S[0, :, 1], C[0, :, 1]):
        x = mpmath.mpf(w) * mpmath.mpf(t)
        s_want = mpmath.sin(x) / w
        c_want = 2 * (mpmath.sin(x / 2) / w) ** 2
        # (to a few ulps, and to what the rounding of the half angle ωτ/2 moves them by: its
        # ulps times the derivatives, cos ωτ/ω and S/ω, as for sin and cos of it)
        assert abs(s - s_want) <= 8e-16 * (abs(s_want) + abs(x * mpmath.cos(x)) / w), t
        assert abs(c - c_want) <= 8e-16 * (abs(c_want) + abs(x * s_want) / w) + 1e-300, t
    assert np.all(S[0, :, 0] == tau) and np.all(C[0, :, 0] == 0.5 * tau * tau)


def test_refined_zeros_are_the_true_zeros_to_the_rounding_of_the_function():
    """``_batch_roots.refine`` on random functions ``c + α₀τ + γ₀τ²/2 + α₁ S₁ + γ₁ C₁`` (a rigid
    mode and an elastic one) bracketed round a sign change: each zero is mpmath's to a few ulps
    of the time plus what the rounding of the function's value (8 ulps of its terms' sizes)
    moves it by, that over the slope; the zeros of a derivative (``rtol=EXTREMUM_RTOL``) to
    that fraction of the time."""
    import mpmath
    from lsc.solvers.exact_chain._batch_modes import Sums
    from lsc.solvers.exact_chain._batch_roots import refine
    from lsc.solvers.exact_chain._roots import EXTREMUM_RTOL

    rng = np.random.default_rng(4)
    n = 200
    w = np.stack([np.zeros(n), 10 ** rng.uniform(0, 4, n)], axis=1)
    alpha, gamma = rng.normal(size=(n, 1, 2)), rng.normal(size=(n, 1, 2)) * w[:, None, :]
    # (a zero at 0.2 to 0.8 of a bracket of up to a radian of the elastic mode)
    a = np.zeros(n)
    b = rng.uniform(0.05, 1.0, n) / w[:, 1]
    zero = rng.uniform(0.2, 0.8, n) * b
    g = Sums(np.zeros((n, 1)), alpha, gamma, w * w, w)
    c = -g.each_at(zero[:, None])
    g = Sums(c, alpha, gamma, w * w, w)
    fa, fb = g.each_at(a[:, None])[:, 0], g.each_at(b[:, None])[:, 0]
    ok = fa * fb < 0
    assert ok.sum() > 100
    mpmath.mp.prec = 120

    def value(j, t, slope=False):
        t, om = mpmath.mpf(t), mpmath.mpf(w[j, 1])
        S, C = mpmath.sin(om * t) / om, 2 * (mpmath.sin(om * t / 2) / om) ** 2
        if slope:
            return alpha[j, 0, 0] + gamma[j, 0, 0] * t + alpha[j, 0, 1] * (1 - om ** 2 * C) \
                + gamma[j, 0, 1] * S
        return c[j, 0] + alpha[j, 0, 0] * t + gamma[j, 0, 0] * t * t / 2 + alpha[j, 0, 1] * S \
            + gamma[j, 0, 1] * C

    r = np.flatnonzero(ok)
    for rtol in (4 * np.finfo(float).eps, EXTREMUM_RTOL):
        got = refine(g.take(r), a[r], b[r], fa[r], fb[r], rtol=rtol)
        for j, t in zip(r, got):
            want = mpmath.findroot(lambda x: value(j, x), mpmath.mpf(zero[j]))
            x = float(want)
            S, C = np.sin(w[j, 1] * x) / w[j, 1], (1 - np.cos(w[j, 1] * x)) / w[j, 1] ** 2
            terms = (abs(c[j, 0]) + abs(alpha[j, 0, 0] * x) + abs(gamma[j, 0, 0]) * x * x / 2
                     + abs(alpha[j, 0, 1] * S) + abs(gamma[j, 0, 1] * C))
            slope = abs(float(value(j, want, slope=True)))
            allowed = rtol * b[j] + 8 * np.finfo(float).eps * (abs(x) + terms / slope)
            assert abs(t - float(want)) <= allowed, (j, t, float(want), allowed)


def _rear_speeds(scene: dict, **values) -> tuple:
    """``scene`` and three members: its rear car's speed moved by 0, 1e-3 and 2e-3 of itself
    (and ``values``, each the same for every member)."""
    v0 = scene["vehicles"][0]["speed"]
    return lsc.load_scene(scene), {"vehicles.0.speed": v0 * (1 + 1e-3 * np.arange(3)),
                                   **{p: np.full(3, x) for p, x in values.items()}}


@pytest.mark.parametrize("k_soft,k_stiff", [(1e2, 1e7), (1e2, 1e8), (10.0, 1e8), (1e2, 1e9)])
def test_a_contact_pushed_through_soft_contacts_is_the_single_solve_member_by_member(
        k_soft, k_stiff):
    """Contacts touching at rest pushed shut through soft contacts (their deformations grow as
    ``τ^(2j+1)``) beside a stiff pair: the batch's restart rule is the single solve's
    (:func:`._solve.start_rounding`, the fastest mode that enters each function, the Taylor
    interval over a radian of it), so it closes them at once as the single solve does. (On
    the batch's old rule, ``tol ω^p`` at every order with the stiff pair's ``ω``, contact 3
    closed 0.11 s late: ΔV 3e-3 and the contact's energy 2e-3 of their scales off the single
    solve's at (10, 1e8) and (100, 1e9), 2e-5 and 6e-5 at (100, 1e7).)"""
    scene, values = _rear_speeds(_far_push(k_soft, k_stiff))
    assert _differing(scene, values, exact_chain.solve_batch(HybridModel(scene), values)) == []


@pytest.mark.parametrize("e", [WATCH_RESTITUTION, 0.9])
def test_five_touching_cars_are_the_single_solve_member_by_member(e, monkeypatch):
    """Five cars at rest touching (test_exact_chain_locks.py's, every restitution ``e``: from
    WATCH_RESTITUTION up, none may lock) struck from behind: the vectorised path solves every
    member itself, its events the single solve's, every metric within 1e-10 of its scale of
    the single solve's. (A chain this graded, 1 to 700 lb and 3e3 to 1e9 lbf/ft, has modes
    that ``eigh`` knows to ``ε κ_max`` only: its slowest elastic mode, κ = 406.648 1/s², was
    2.3e-10 off in the single solve's eigensolve and 3.6e-11 in the batch's (against mpmath),
    which parted a peak acceleration by 1.2e-8 of its scale; both now take every eigenvalue
    from the SVD of the factor, to rounding (tests/test_exact_chain_modes.py). On the batch's
    old restart rule the contacts
    pushed shut closed late: at e = 0.9 the peak acceleration was 249 times its scale off the
    single solve's; at 0.05 the members chattered to the hand-off's event count.)"""
    alone = []
    original = _batch.solve_alone
    monkeypatch.setattr(_batch, "solve_alone",
                        lambda solve, model, values, members, *a, **kw:
                        alone.extend(members) or original(solve, model, values, members, *a, **kw))
    scene, values = _rear_speeds(TOUCHING_FIVE, **{
        f"contacts.{k}.unloading.restitution": e for k in range(4)})
    out = exact_chain.solve_batch(HybridModel(scene), values)
    assert alone == []
    assert _differing(scene, values, out, rtol=1e-10) == []


def test_a_touch_at_rest_shut_by_a_neighbour_is_solved_in_the_batch(monkeypatch):
    """Cars 2 and 3 touching at the same speed, struck through a 0.86 ft gap 5.25 s later: at
    the strike contact 2's closing rate is zero to the rounding of its deformation through the
    stiff modes (k D of a few ulps), which the batch's start tolerance of a rate includes as
    the single solve's does: the member takes its 6 events in the batch, the single solve's
    numbers. (Without that term the rate fired max deformation, then the reload, at one
    instant, over and over: the member reached the hand-off's 200 events and went to the single
    solve; member 2029 of bench_chain_sweep.py's 20,000.)"""
    alone = []
    original = _batch.solve_alone
    monkeypatch.setattr(_batch, "solve_alone",
                        lambda solve, model, values, members, *a, **kw:
                        alone.extend(members) or original(solve, model, values, members, *a, **kw))
    scene, _ = random_chains(3, 1, 1)
    values = {k: np.array([v]) for k, v in {
        "vehicles.0.mass": 84.58964243582457, "vehicles.0.speed": 10.857601598573206,
        "vehicles.1.mass": 115.35014761678096, "vehicles.1.speed": 10.693214683960552,
        "vehicles.2.mass": 59.2092272898006, "vehicles.2.speed": 10.693214683960552,
        "contacts.0.loading.stiffness": 1743266.229126959,
        "contacts.0.unloading.restitution": 0.9933792202716892,
        "contacts.0.gap": 0.8637340985901553,
        "contacts.1.loading.stiffness": 2652646.5250337957,
        "contacts.1.unloading.restitution": 0.5637672274215909,
        "contacts.1.gap": 0.0}.items()}
    out = exact_chain.solve_batch(HybridModel(scene), values)
    assert alone == []
    assert len(_single(scene, values, 0).events) == 6
    assert _differing(scene, values, out) == []


#: A chain whose stiff, near-plastic rear contact chatters while the soft front one is loaded:
#: 226 events (member 518 of bench_chain_sweep.py's 20,000).
CHATTER = {"vehicles.0.mass": 425.1947370235454, "vehicles.0.speed": 23.99428685562417,
           "vehicles.1.mass": 350.8367781377573, "vehicles.1.speed": 23.60162333125918,
           "vehicles.2.mass": 412.0702253147719, "vehicles.2.speed": 19.11184986072726,
           "contacts.0.loading.stiffness": 8137573.563619408,
           "contacts.0.unloading.restitution": 0.10153149455336491, "contacts.0.gap": 0.0,
           "contacts.1.loading.stiffness": 6019.474941675754,
           "contacts.1.unloading.restitution": 0.7054647820951969,
           "contacts.1.gap": 0.003166371812572444}


def _handed(monkeypatch) -> list:
    """The members the batch hands to the single solve (filled as it runs)."""
    alone = []
    original = _batch.solve_alone
    monkeypatch.setattr(_batch, "solve_alone",
                        lambda solve, model, values, members, *a, **kw:
                        alone.extend(members) or original(solve, model, values, members, *a, **kw))
    return alone


def test_a_chattering_member_is_taken_on_from_the_hand_off(monkeypatch):
    """A member still running at the hand-off's event count is taken on from the batch's state
    by the single solve's own segments, not solved again from t = 0: the single solve's numbers
    (to the rounding the tests allow), its 226 events."""
    alone = _handed(monkeypatch)
    scene, _ = random_chains(3, 1, 1)
    values = {k: np.array([v]) for k, v in CHATTER.items()}
    out = exact_chain.solve_batch(HybridModel(scene), values)
    assert alone == []
    assert len(_single(scene, values, 0).events) == 226 > _batch.HANDOFF_EVENTS
    assert _differing(scene, values, out) == []


def test_a_chattering_members_numbers_do_not_depend_on_the_members_beside_it():
    """A member taken on at the hand-off has the same numbers, bit for bit, in a batch of its
    own and among others still running past the hand-off (a sweep's chunks, hence its
    workers, must not change a number): the hand-off is the member's own event count, not
    how many members are left running."""
    scene, _ = random_chains(3, 1, 1)
    model = HybridModel(scene)
    one = exact_chain.solve_batch(model, {k: np.array([v]) for k, v in CHATTER.items()})
    many_ = exact_chain.solve_batch(model, {k: np.full(40, v) for k, v in CHATTER.items()})
    for name in METRICS:
        assert np.array_equal(many_["metrics"][name],
                              np.repeat(one["metrics"][name], 40, axis=0), equal_nan=True), name


def test_a_member_taken_on_that_reaches_the_event_limit_has_the_single_solves_message(
        monkeypatch):
    alone = _handed(monkeypatch)
    scene, _ = random_chains(3, 1, 1)
    values = {k: np.array([v]) for k, v in CHATTER.items()}
    out = exact_chain.solve_batch(HybridModel(scene), values, max_events=210)
    assert alone == [0]
    assert out["status"][0] == _single(scene, values, 0, max_events=210)
    assert out["status"][0].startswith("SimulationError: event limit reached (210 events by t = ")


def test_a_segment_the_batch_search_cannot_decide_is_taken_on_from_its_start(monkeypatch):
    """Three cars touching at one speed, the last one 0.86 ft ahead behind a stiff contact
    (member 582 of random 4-car chains, seed 5; 17 events): a segment the batch's sampled
    search cannot decide (its bound clears no interval within its levels: undecided) is taken
    on from its start by the single solve's own search (its Taylor test, its bisection), not
    solved again from t = 0: the single solve's numbers. (The search could not decide one of
    this member's segments while the deformations were differences of positions, the touching
    cars' rounding; carried from segment to segment they are exact, and it decides them all:
    here it is told once, at the fifth segment, that it could not.)"""
    alone = _handed(monkeypatch)
    taken, calls = [], []
    search = _batch.earliest

    def undecided_once(g, armed, start, limit):
        tau, which, undecided = search(g, armed, start, limit)
        calls.append(1)
        return tau, which, (np.ones_like(undecided) if len(calls) == 5 else undecided)
    monkeypatch.setattr(_batch, "earliest", undecided_once)
    original = _batch._Batch._resume
    monkeypatch.setattr(_batch._Batch, "_resume",
                        lambda self, i, w, *a: taken.append(int(w["nev"][i]))
                        or original(self, i, w, *a))
    scene, _ = random_chains(4, 1, 1)
    values = {k: np.array([v]) for k, v in {
        "vehicles.0.mass": 337.6880992450607, "vehicles.0.speed": 3.0291824529346307,
        "vehicles.1.mass": 483.2195719440055, "vehicles.1.speed": 3.0291824529346307,
        "vehicles.2.mass": 100.19940206757762, "vehicles.2.speed": 3.0291824529346307,
        "vehicles.3.mass": 126.30719067220738, "vehicles.3.speed": 0.0,
        "contacts.0.loading.stiffness": 1935.947428570366,
        "contacts.0.unloading.restitution": 0.951327196601014, "contacts.0.gap": 0.0,
        "contacts.1.loading.stiffness": 1071.447313640242,
        "contacts.1.unloading.restitution": 0.32388837980755536, "contacts.1.gap": 0.0,
        "contacts.2.loading.stiffness": 7352054.058338084,
        "contacts.2.unloading.restitution": 0.3269638311222375,
        "contacts.2.gap": 0.8570282970437636}.items()}
    out = exact_chain.solve_batch(HybridModel(scene), values)
    assert alone == [] and len(taken) == 1 and 0 < taken[0] < _batch.HANDOFF_EVENTS
    assert _differing(scene, values, out) == []


def test_the_column_reductions_are_numpys():
    """``_batch_modes.mmax, mmin, many, mall, first_true`` (column by column over a short last
    axis) give NumPy's reductions bit for bit, NaN and infinities included, on last axes
    short and long (NumPy's own there)."""
    from lsc.solvers.exact_chain._batch_modes import first_true, mall, many, mmax, mmin
    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 9, 15, 16, 40):
        x = rng.normal(size=(50, 4, n))
        x[rng.random(x.shape) < 0.05] = np.nan
        x[rng.random(x.shape) < 0.05] = -np.inf
        b = rng.random(x.shape) < 0.1
        assert np.array_equal(mmax(x), np.max(x, axis=-1), equal_nan=True), n
        assert np.array_equal(mmin(x), np.min(x, axis=-1), equal_nan=True), n
        assert np.array_equal(many(b), np.any(b, axis=-1)), n
        assert np.array_equal(mall(~b), np.all(~b, axis=-1)), n
        assert np.array_equal(first_true(b, n), np.where(b.any(-1), np.argmax(b, -1), n)), n
        assert (~b.any(-1)).any() and b.any(-1).any()


def test_many_rows_is_numpys():
    """``_batch_modes.many_rows`` (a pass per function) is ``np.any(x, axis=1)``, on few
    functions and many (NumPy's own there)."""
    from lsc.solvers.exact_chain._batch_modes import many_rows
    rng = np.random.default_rng(5)
    for F in (1, 2, 3, 6, 16, 20):
        b = rng.random((40, F, 9)) < 0.05
        assert np.array_equal(many_rows(b), np.any(b, axis=1)), F
        assert (~np.any(b, axis=1)).any() and np.any(b, axis=1).any()


def test_searched_functions_first_is_a_stable_argsort():
    """``_batch_roots._searched_first`` (the pattern's order looked up where the rows
    outnumber the patterns) is ``np.argsort(~search, axis=1, kind="stable")``, both ways."""
    from lsc.solvers.exact_chain._batch_roots import _searched_first
    rng = np.random.default_rng(6)
    for b, F in ((5, 6), (64, 6), (3000, 6), (600, 9), (100, 15), (40, 1)):
        search = rng.random((b, F)) < 0.4
        search[0] = False
        assert np.array_equal(_searched_first(search),
                              np.argsort(~search, axis=1, kind="stable")), (b, F)


def test_the_stacked_basis_is_the_basis():
    """``_batch_modes.stacked_basis`` (``[S; C]`` laid out mode by mode for the search's
    products) holds :func:`_batch_modes.basis`'s numbers bit for bit: mode 0 rigid in every
    member, another rigid in some, and none rigid beyond the first."""
    from lsc.solvers.exact_chain._batch_modes import basis, stacked_basis
    rng = np.random.default_rng(4)
    tau = np.cumsum(rng.random((6, 9)) * 1e-3, axis=1)
    for w in (np.c_[np.zeros(6), rng.random((6, 2)) * 1e3],
              np.c_[np.zeros(6), [0.0, 5.0, 0.0, 7.0, 1e4, 0.0], rng.random(6) * 1e3],
              rng.random((6, 3)) * 1e3 + 1.0):
        S, C = basis(w[:, None, :], tau)
        SC = stacked_basis(w, tau)
        n = w.shape[1]
        assert np.array_equal(SC[:, :n], np.swapaxes(S, 1, 2))
        assert np.array_equal(SC[:, n:], np.swapaxes(C, 1, 2))


def test_the_batch_carries_its_deformations_far_down_the_road():
    """The chains 111 and 244 ft down the road (tests/test_exact_chain.py's FAR, FAR_STIFF) by
    the vectorised path: its deformations carried from segment to segment as the single
    solve's, not differences of positions, so their energy balances close to 1e-12 of the
    relative kinetic energy (3.4e-14 and 1.2e-14; taken from the positions: 6.1e-12 and
    1.3e-12)."""
    from hard.common import relative_ke
    from test_exact_chain import FAR, FAR_STIFF

    for scene in (FAR, FAR_STIFF):
        m = np.array([v["mass"] for v in scene["vehicles"]])
        v0 = [v["speed"] for v in scene["vehicles"]]
        out = exact_chain.solve_batch(HybridModel(lsc.load_scene(scene)),
                                      {"vehicles.0.speed": np.array([v0[0]])})
        assert out["status"] == ["ok"]
        met = {name: a[0] for name, a in out["metrics"].items()}
        ke0 = relative_ke(m, v0)
        lost = ke0 - relative_ke(m, met["v_final"])
        assert abs(lost - np.sum(met["energy_absorbed"] - met["energy_returned"])) <= 1e-12 * ke0
