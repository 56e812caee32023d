"""Effects a scene names: damping laws, braking, bumper failure, chains — and only those."""

import numpy as np
import pytest

import lsc
from lsc.contact import brach_restitution, hunt_crossley_a, kelvin_restitution
from lsc.model import HybridModel
from helpers import chain as vehicle_chain, max_rel_error

M1, M2 = 1400.0, 1000.0
MU = M1 * M2 / (M1 + M2)


def damped(law, v0=3.0, m1=M1, m2=M2, **keys):
    return {"units": "SI", "vehicles": [{"mass": m1, "speed": v0}, {"mass": m2, "speed": 0.0}],
            "contacts": [{"law": law, **keys}]}


# ------------------------------------------------------------------ Kelvin
@pytest.mark.parametrize("zeta", [0.05, 0.3, 0.7])
def test_kelvin_against_its_closed_form(zeta):
    k, v0 = 2.0e5, 3.0
    w = np.sqrt(k / MU)
    wd = w * np.sqrt(1 - zeta**2)
    c = 2 * zeta * np.sqrt(k * MU)
    r = lsc.solve(damped("kelvin", v0, stiffness=k, damping=c), method="scipy", rtol=1e-12)
    t_max = [ev.time for ev in r.events if ev.kind == "max_deformation"][0]
    assert t_max == pytest.approx(np.arccos(zeta) / wd, rel=1e-8)
    D_max = v0 / wd * np.exp(-zeta * w * t_max) * np.sin(wd * t_max)
    assert r.max_deformation[0] == pytest.approx(D_max, rel=1e-8)
    assert r.duration == pytest.approx(2 * np.arccos(zeta) / wd, rel=1e-8)
    e = np.exp(-2 * zeta * np.arccos(zeta) / np.sqrt(1 - zeta**2))
    assert r.restitution[0] == pytest.approx(e, rel=1e-8)
    assert r.restitution_energy[0] == pytest.approx(e, rel=1e-8)
    # the force jumps to c v0 at t = 0: the known flaw of the Kelvin model
    assert r.force[0, 0] == pytest.approx(c * v0, rel=1e-12)


def test_kelvin_zeta_03_gives_0451_and_restitution_input_is_exact():
    assert float(kelvin_restitution(0.3)) == pytest.approx(0.451, abs=5e-4)
    r = lsc.solve(damped("kelvin", stiffness=2.0e5, restitution=0.451), method="scipy",
                  rtol=1e-12)
    assert r.restitution[0] == pytest.approx(0.451, abs=1e-9)


# ------------------------------------------------------------------ Hunt–Crossley
@pytest.mark.parametrize("n", [1.0, 1.5, 2.0])
@pytest.mark.parametrize("e", [0.2, 0.5, 0.9])
def test_hunt_crossley_restitution_relation(n, e):
    a = hunt_crossley_a(e)
    assert a * (1 + e) == pytest.approx(np.log((1 + a) / (1 - a * e)), rel=1e-12)
    v0 = 2.5
    # given as a damping alpha = a / v0: the achieved restitution must be e
    r = lsc.solve(damped("hunt-crossley", v0, stiffness=5e6, exponent=n, damping=a / v0),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(e, abs=1e-8)
    assert r.force[0, 0] == 0.0  # no force jump: F ∝ D^n
    # given as the restitution itself
    r2 = lsc.solve(damped("hunt-crossley", v0, stiffness=5e6, exponent=n, restitution=e),
                   method="scipy", rtol=1e-12)
    assert r2.restitution[0] == pytest.approx(e, abs=1e-8)
    assert r2.restitution_energy[0] == pytest.approx(e, abs=1e-8)


# ------------------------------------------------------------------ target-restitution derivatives
@pytest.mark.parametrize("law, key, conv", [("KelvinLaw", "zeta", "kelvin_zeta"),
                                            ("HuntCrossleyLaw", "a", "hunt_crossley_a")])
def test_target_restitution_numbers_trace_with_their_declared_derivative(law, key, conv):
    """A law's numbers built from a target restitution (a root find on NumPy) trace under JAX:
    the values are the NumPy construction's, under jit and vmap, and jax.jvp gives the
    derivative the law declares (implicit function theorem) = differences of the converter."""
    jax = pytest.importorskip("jax")
    jnp = jax.numpy
    import lsc.contact as contact
    from lsc import laws

    cls, convert = getattr(laws, law), getattr(contact, conv)
    values = {"stiffness": 1e5, "damping": None, "exponent": 1.0}
    es = np.array([0.2, 0.6, 0.95])

    def numbers(e):
        return cls.build({**values, "restitution": e}, 1000.0, jnp)[key]

    with jax.enable_x64(True):
        got = np.asarray(jax.jit(jax.vmap(numbers))(jnp.asarray(es)))
        slopes = [float(jax.jvp(numbers, (jnp.asarray(e),), (jnp.asarray(1.0),))[1]) for e in es]
    assert got == pytest.approx([float(cls.build({**values, "restitution": e}, 1000.0, np)[key])
                                 for e in es], rel=1e-14)
    h = 1e-6
    assert slopes == pytest.approx([(convert(e + h) - convert(e - h)) / (2 * h) for e in es],
                                   rel=1e-6)


# ------------------------------------------------------------------ Brach
@pytest.mark.parametrize("c1, c2", [(0.0, 4e4), (2e4, 8e4), (5e4, 5e4)])
def test_brach_restitution_against_its_energy_integral(c1, c2):
    k, v0 = 2.0e5, 3.0
    r = lsc.solve(damped("brach", v0, stiffness=k, damping=c1, damping_restitution=c2),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(brach_restitution(k, c1, c2, v0, MU), abs=1e-8)
    assert r.force[0, 0] == 0.0  # F = D (k + c Ḋ) starts at zero


def test_brach_restitution_target_sets_c2():
    r = lsc.solve(damped("brach", 3.0, stiffness=2.0e5, damping=1e4, restitution=0.6),
                  method="scipy", rtol=1e-12)
    assert r.restitution[0] == pytest.approx(0.6, abs=1e-8)


def test_damping_law_energy_balance():
    r = lsc.solve(damped("kelvin", 3.0, stiffness=2.0e5, restitution=0.5), method="scipy",
                  rtol=1e-12)
    ke0 = 0.5 * M1 * 9.0
    ke1 = 0.5 * (M1 * r.v_final[0] ** 2 + M2 * r.v_final[1] ** 2)
    lost = r.energy_absorbed[0] - r.energy_returned[0]
    assert ke0 - ke1 == pytest.approx(lost, rel=1e-9)
    assert r.energy_absorbed[0] == pytest.approx(0.5 * MU * 9.0, rel=1e-9)


def test_damping_law_batch_numbers_are_those_of_each_member_scene():
    """A batch of swept masses and damping keys holds, member by member, the numbers of the
    member's own scene: Kelvin's damping c = 2 ζ √(kμ) stays the scene's c when the masses
    change (ζ follows μ), and the other laws' keys land where their scenes put them."""
    from lsc import parameters

    masses = np.array([700.0, 1400.0, 2800.0])
    cases = [("kelvin", {"stiffness": 2.0e5, "damping": 4000.0}, {"vehicles.0.mass": masses}),
             ("kelvin", {"stiffness": 2.0e5, "damping": 4000.0},
              {"vehicles.1.mass": masses, "contacts.0.damping": [1e3, 2e3, 5e3]}),
             ("hunt-crossley", {"stiffness": 2.0e5, "exponent": 1.5, "restitution": 0.5},
              {"contacts.0.restitution": [0.3, 0.6, 0.9], "vehicles.0.mass": masses}),
             ("brach", {"stiffness": 2.0e5, "damping": 1e4, "damping_restitution": 2e4},
              {"contacts.0.damping": [0.0, 1e3, 1e4], "contacts.0.stiffness": [1e5, 2e5, 3e5]})]
    for law, keys, values in cases:
        base = lsc.Scene.load(damped(law, **keys))
        values = {p: np.asarray(v, float) for p, v in values.items()}
        batch = parameters.batch_params(HybridModel(base), values)
        for j in range(3):
            member = base.with_values({p: float(v[j]) for p, v in values.items()})
            own = HybridModel(member).params
            np.testing.assert_array_equal(batch["m"][j], own["m"])
            for name, number in own["contacts"][0].items():
                np.testing.assert_allclose(batch["contacts"][0][name][j], number, rtol=1e-15,
                                           err_msg=f"{law} {name} member {j}")
            if law == "kelvin":
                m1, m2 = batch["m"][j]
                c = 2 * batch["contacts"][0]["zeta"][j] * np.sqrt(
                    batch["contacts"][0]["k"][j] * m1 * m2 / (m1 + m2))
                assert c == pytest.approx(member.contacts[0].law.damping, rel=1e-14)


# ------------------------------------------------------------------ braking
def braked(v1=2.0, mu1=None, mu2=None, mus2=None, k=2.0e5, e=0.5, m1=M1, m2=M2, g=9.81):
    veh = [{"mass": m1, "speed": v1}, {"mass": m2, "speed": 0.0}]
    if mu1:
        veh[0]["brake"] = {"mu": mu1}
    if mu2:
        veh[1]["brake"] = {"mu": mu2, "mu_static": mus2 or mu2}
    return {"units": "SI", "g": g, "vehicles": veh,
            "contacts": [{"loading": {"stiffness": k}, "unloading": {"restitution": e}}]}


@pytest.mark.parametrize("method", ["scipy", "exact"])
def test_braked_target_below_breakaway_never_moves(method):
    # the target stays put, so the bullet meets a wall: F_max = v0 √(k m1) < μs m2 g
    v0, k, m1 = 0.3, 2.0e4, 800.0
    fmax = v0 * np.sqrt(k * m1)
    mus = 1.2
    assert fmax < mus * 3000 * 9.81
    opts = {"rtol": 1e-12} if method == "scipy" else {}
    r = lsc.solve(braked(v0, mu2=0.9, mus2=mus, k=k, m1=m1, m2=3000.0, e=0.5), method=method,
                  **opts)
    assert np.all(r.x[:, 1] == 0.0) and np.all(r.v[:, 1] == 0.0)
    assert r.peak_force[0] == pytest.approx(fmax, rel=1e-9)
    assert r.v_final[0] == pytest.approx(-0.5 * v0, rel=1e-9)  # rebounds off a wall with e


@pytest.mark.parametrize("method, tol", [("scipy", 1e-9), ("exact", 1e-12)])
def test_bullet_braking_throughout_against_hand_closed_form(method, tol):
    v0, k, e, mu1, g = 3.0, 2.0e5, 0.4, 0.7, 9.81
    opts = {"rtol": 1e-12} if method == "scipy" else {}
    r = lsc.solve(braked(v0, mu1=mu1, k=k, e=e, g=g), method=method, **opts)
    assert r.method.startswith(method)
    # relative motion: D'' = -F/μ - μ1 g, loading F = k D, then unloading k/e² to D_perm
    w = np.sqrt(k / MU)
    d = mu1 * g / w**2
    A, B = v0 / w, d
    t_m = np.arctan2(A, B) / w
    D_max = -d + np.hypot(A, B)
    D_perm = D_max * (1 - e**2)
    ku = k / e**2
    wu = np.sqrt(ku / MU)
    du = mu1 * g / wu**2
    amp = D_max - D_perm + du
    tau = np.arccos(du / amp) / wu
    impulse = k * (-d * t_m + A / w * (1 - np.cos(w * t_m)) + B / w * np.sin(w * t_m)) \
        + ku * (-du * tau + amp * np.sin(wu * tau) / wu)
    T = t_m + tau
    assert r.max_deformation[0] == pytest.approx(D_max, rel=tol)
    assert r.duration == pytest.approx(T, rel=tol)
    assert r.v_final[1] == pytest.approx(impulse / M2, rel=tol)
    assert r.v_final[0] == pytest.approx(v0 - impulse / M1 - mu1 * g * T, rel=tol)
    # momentum changes by exactly the friction impulse
    dp = M1 * r.delta_v[0] + M2 * r.delta_v[1]
    assert dp == pytest.approx(-mu1 * M1 * g * T, rel=tol)
    # for a linear loading line a constant friction force leaves the velocity restitution at e
    # (its work in compression and in restitution scales with D_max - D_perm = e² D_max) ...
    assert r.restitution[0] == pytest.approx(e, rel=tol)


def test_braking_with_a_nonlinear_curve_separates_the_two_restitutions():
    # ... but not for a curved loading branch: report both
    scene = braked(3.0, mu1=0.7, e=0.4)
    scene["contacts"][0]["loading"] = {"table": [[0, 0], [0.01, 500], [0.05, 8000], [0.3, 9e4]]}
    r = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert r.restitution_energy[0] == pytest.approx(0.4, rel=1e-12)
    assert abs(r.restitution[0] - 0.4) > 1e-3
    ex = lsc.solve(scene, method="exact")
    assert ex.restitution_energy[0] == pytest.approx(0.4, rel=1e-14)
    assert ex.restitution[0] == pytest.approx(r.restitution[0], rel=1e-9)


@pytest.mark.parametrize("method", ["scipy", "exact"])
def test_braked_vehicles_stop_and_the_series_shows_it(method):
    opts = {"rtol": 1e-10} if method == "scipy" else {}
    r = lsc.solve(braked(3.0, mu1=0.7, mu2=0.7), method=method, t_end=2.0, **opts)
    kinds = [ev.kind for ev in r.events]
    assert kinds.count("stop") == 2
    assert np.all(np.abs(r.v[-1]) < 1e-12)
    assert r.v_final[1] > 0  # the post-crash velocity, not the velocity at rest


# ------------------------------------------------------------------ failure
def test_failure_force_reported_with_its_time():
    scene = {"units": "US", "g": "32.2 ft/s^2",
             "vehicles": [{"weight": 3500, "speed": 5}, {"weight": 3500, "speed": 0}],
             "contacts": [{"loading": {"stiffness": 18462}, "unloading": {"restitution": 0.8},
                           "failure": {"force": "4500 lbf"}}]}
    mu = 3500 / 32.2 / 2
    w = np.sqrt(18462 / mu)
    fmax = 5 * np.sqrt(18462 * mu)
    t_fail = np.arcsin(4500 / fmax) / w
    for method in ("closed-form", "scipy"):
        r = lsc.solve(scene, method=method, rtol=1e-12) if method == "scipy" else \
            lsc.solve(scene, method=method)
        assert r.failed[0]
        assert r.failure_time[0] == pytest.approx(t_fail, rel=1e-9)
    lower = lsc.Scene.load(scene).with_values({"vehicles.0.speed": 4.0})
    assert not lsc.solve(lower).failed[0]


# ------------------------------------------------------------------ post-failure loading
# Linear loading k1 failing at FF, then the post-failure line F = F0 + K2 (D - D_f) with
# F0 = FF/2: the force drops by half at D_f (SI: m, N, kg).
K1, FF, K2, F0, E_PF = 2.0e5, 2.0e4, 5.0e4, 1.0e4, 0.3
PF_LINE = {"table": [[0.0, F0], [1.0, F0 + K2]]}


def post_failure(post=PF_LINE, v1=4.0, v2=0.5, loading=None, e=E_PF, failure=FF, **extra):
    c = {"loading": loading or {"stiffness": K1}, "unloading": {"restitution": e},
         "failure": {"force": failure, **({} if post is None else {"post_failure": post})}}
    return {"units": "SI", "vehicles": [{"mass": M1, "speed": v1}, {"mass": M2, "speed": v2}],
            "contacts": [c], **extra}


def solve_all(scene, methods=("exact", "scipy", "diffrax")):
    """Each backend at its tightest (diffrax only where installed)."""
    out = {}
    for m in methods:
        if m == "diffrax":
            pytest.importorskip("diffrax")
            out[m] = lsc.solve(scene, method=m, integrator="Dopri8", rtol=1e-13)
        elif m == "scipy":
            out[m] = lsc.solve(scene, method=m, integrator="DOP853", rtol=1e-12)
        else:
            out[m] = lsc.solve(scene, method=m)
    return out


def post_failure_closed_form(v0, m1=M1, m2=M2, e=E_PF):
    """Hand-derived two-car crash on the spliced curve: energy gives D_max, the harmonic
    motion on each straight piece gives the times."""
    mu = m1 * m2 / (m1 + m2)
    E0 = 0.5 * mu * v0 ** 2
    Df = FF / K1
    Ef = 0.5 * FF * Df
    # area under the spliced curve up to D_max equals E0: Ef + F0 x + K2 x²/2 = E0
    x = 2.0 * (E0 - Ef) / (F0 + np.sqrt(F0 ** 2 + 2.0 * K2 * (E0 - Ef)))
    Dmax, Fmax = Df + x, F0 + K2 * x
    Dperm = Dmax - 2.0 * e ** 2 * E0 / Fmax
    w1, w2 = np.sqrt(K1 / mu), np.sqrt(K2 / mu)
    t_fail = np.arcsin(Df * w1 / v0) / w1
    wf = np.sqrt(v0 ** 2 - (w1 * Df) ** 2)             # closing speed at failure
    t_max = t_fail + np.arctan2(wf / w2, F0 / K2) / w2  # u = x + F0/K2 is harmonic
    wu = np.sqrt(Fmax / (Dmax - Dperm) / mu)            # the unloading line's frequency
    return {"Df": Df, "max_deformation": Dmax, "peak_force": max(Fmax, FF), "Fmax": Fmax,
            "permanent_deformation": Dperm, "energy_absorbed": E0,
            "energy_returned": e ** 2 * E0, "restitution": e, "restitution_energy": e,
            "delta_v": np.array([-(1 + e) * m2 * v0 / (m1 + m2), (1 + e) * m1 * v0 / (m1 + m2)]),
            "failure_time": t_fail, "t_max": t_max, "duration": t_max + 0.5 * np.pi / wu}


def _close(a, b, tol, what):
    a, b = np.atleast_1d(np.asarray(a, float)), np.atleast_1d(np.asarray(b, float))
    err = max_rel_error(a, b)
    assert err <= tol, f"{what}: {a} vs {b} (rel {err:.2e})"


@pytest.mark.parametrize("method", ["exact", "scipy", "diffrax"])
def test_post_failure_force_drop_against_hand_closed_form(method):
    r = solve_all(post_failure(), (method,))[method]
    cf = post_failure_closed_form(3.5)
    assert cf["Fmax"] < FF  # the force drop matters: the peak is the failure force itself
    for name in ("max_deformation", "peak_force", "permanent_deformation", "energy_absorbed",
                 "energy_returned", "restitution", "restitution_energy", "delta_v",
                 "failure_time", "duration"):
        _close(getattr(r, name), cf[name], 1e-9, name)
    assert r.failed[0]
    kinds = [ev.kind for ev in r.events]
    assert kinds == ["contact", "failure", "max_deformation", "separation"]
    _close([ev.time for ev in r.events if ev.kind == "max_deformation"], cf["t_max"], 1e-9,
           "time of max deformation")
    # the force steps from FF down to F0 at the failure point
    Fb = r.force[r.t == r.failure_time[0], 0]
    assert np.sort(Fb) == pytest.approx([F0, FF], rel=1e-9)


@pytest.mark.parametrize("method", ["exact", "scipy", "diffrax"])
def test_post_failure_conserves_momentum_and_balances_energy(method):
    r = solve_all(post_failure(), (method,))[method]
    m = np.array([M1, M2])
    v0 = np.array([4.0, 0.5])
    p0 = m @ v0
    assert abs(m @ r.v_final - p0) <= 1e-12 * p0
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-12 * p0
    lost = 0.5 * m @ v0 ** 2 - 0.5 * m @ r.v_final ** 2
    _close(lost, r.energy_absorbed[0] - r.energy_returned[0], 1e-10, "energy balance")
    # absorbed = the area under the spliced curve up to D_max (the law's own curve)
    curve = HybridModel(lsc.Scene.load(post_failure())).laws[0].loading
    _close(r.energy_absorbed, curve.energy(r.max_deformation[0]), 1e-12, "area")


@pytest.mark.parametrize("method", ["exact", "scipy", "diffrax"])
def test_post_failure_not_reached_changes_nothing(method):
    slow = post_failure(v1=1.5)   # closing at 1 m/s: F_max = 1 * sqrt(K1 mu) < FF
    with_pf = solve_all(slow, (method,))[method]
    without = solve_all(post_failure(None, v1=1.5), (method,))[method]
    assert not with_pf.failed[0] and not without.failed[0]
    assert with_pf.peak_force[0] < FF
    for name in ("delta_v", "max_deformation", "permanent_deformation", "peak_force", "duration",
                 "energy_absorbed", "energy_returned", "restitution"):
        _close(getattr(with_pf, name), getattr(without, name), 1e-12, name)
    assert [ev.kind for ev in with_pf.events] == [ev.kind for ev in without.events]


# a measured-like loading that reaches the failure force inside a segment, then post-failure
# tables starting below it (a drop) and above it (a jump, then a falling piece)
PF_LOADING = {"table": [[0, 0], [0.05, 8000], [0.12, 20000], [0.3, 26000]]}
PF_DOWN = {"table": [[0, 6000], [0.05, 9000], [0.5, 40000]]}
PF_UP = {"table": [[0, 24000], [0.08, 21000], [0.5, 45000]]}


@pytest.mark.parametrize("post", [PF_DOWN, PF_UP], ids=["jump-down", "jump-up"])
def test_post_failure_tables_agree_across_backends(post):
    scene = post_failure(post, v1=5.0, v2=0.0, loading=PF_LOADING, failure=18000.0)
    scene["contacts"][0]["unloading"] = {"table": [[0.4, 30000], [0.35, 12000], [0.3, 0]]}
    rs = solve_all(scene)
    ex = rs["exact"]
    Df = 0.05 + (18000 - 8000) / 12000 * 0.07
    assert ex.failed[0] and ex.max_deformation[0] > Df + 0.08  # past the falling piece
    for m, r in rs.items():
        assert [ev.kind for ev in r.events] == [ev.kind for ev in ex.events], m
        for name in ("delta_v", "max_deformation", "permanent_deformation", "peak_force",
                     "failure_time", "duration", "energy_absorbed", "restitution_energy"):
            _close(getattr(r, name), getattr(ex, name), 1e-9, f"{m} {name}")
    jump = post["table"][0][1]
    Fb = ex.force[ex.t == ex.failure_time[0], 0]
    assert np.sort(Fb) == pytest.approx(sorted([18000.0, jump]), rel=1e-12)
    assert ex.peak_force[0] == pytest.approx(max(18000.0, jump, np.max(ex.force)), rel=1e-12)


@pytest.mark.parametrize("method", ["exact", "scipy", "diffrax"])
def test_failure_time_is_when_the_deformation_first_reaches_the_failure_point(method):
    scene = post_failure(PF_DOWN, v1=5.0, v2=0.0, loading=PF_LOADING, failure=18000.0)
    r = solve_all(scene, (method,))[method]
    Df = 0.05 + (18000 - 8000) / 12000 * 0.07
    tf = r.failure_time[0]
    at = np.nonzero(r.t == tf)[0]
    assert at.size == 2  # the end of the segment before the failure and the start of the next
    assert r.deformation[at, 0] == pytest.approx([Df, Df], rel=1e-10)
    assert np.all(r.deformation[r.t < tf, 0] < Df)
    # the time itself: the exact backend's, and the closed form's on the linear loading
    ref = lsc.solve(scene, method="exact").failure_time[0]
    _close(tf, ref, 1e-10, "failure time")
    lin = solve_all(post_failure(), (method,))[method]
    _close(lin.failure_time, post_failure_closed_form(3.5)["failure_time"], 1e-9, "linear")


def test_post_failure_stiffness_extends_and_a_table_that_ends_says_so():
    # a stiffness: F = K2 (D - D_f) after the failure, the force dropping to zero there
    r = lsc.solve(post_failure({"stiffness": K2}), method="exact")
    mu = M1 * M2 / (M1 + M2)
    Df = FF / K1
    x = np.sqrt(2 * (0.5 * mu * 3.5 ** 2 - 0.5 * FF * Df) / K2)
    assert r.max_deformation[0] == pytest.approx(Df + x, rel=1e-12)
    assert lsc.solve(post_failure({"stiffness": K2})).method == "exact"  # auto
    assert f"failed at t = {r.failure_time[0]:.6g} s, then the post-failure curve" in r.summary()
    assert "(20000 N): not reached" in lsc.solve(post_failure(v1=1.5)).summary()
    short = post_failure({"table": [[0, F0], [0.1, F0 + 0.1 * K2]]})
    for method in ("exact", "scipy"):
        with pytest.raises(lsc.SimulationError, match="post-failure loading table ends"):
            lsc.solve(short, method=method)


def test_post_failure_in_a_chain_that_reloads_balances_momentum_and_energy():
    pf = {"force": 12000, "post_failure": {"table": [[0, 6000], [0.05, 9000], [1.0, 60000]]}}
    m = np.array([2000.0, 300.0, 2000.0])
    scene = {"units": "SI",
             "vehicles": [{"mass": mi, "speed": v} for mi, v in zip(m, (5.0, 0.0, 0.0))],
             "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.5},
                           "failure": pf},
                          {"loading": {"table": [[0, 0], [0.1, 10000], [0.3, 14000]]},
                           "unloading": {"restitution": 0.5}, "failure": pf}]}
    r = lsc.solve(scene, method="scipy", rtol=1e-11)
    kinds = [ev.kind for ev in r.events]
    assert kinds.count("failure") == 2 and "reload_past_max" in kinds
    assert np.all(r.failed)
    assert abs(m @ r.v_final - 1e4) <= 1e-12 * 1e4
    lost = 0.5 * m[0] * 25.0 - 0.5 * m @ r.v_final ** 2
    _close(lost, np.sum(r.energy_absorbed - r.energy_returned), 1e-9, "energy balance")


def test_post_failure_reference_and_closed_form_refuse_with_their_reason():
    for method, reason in (("reference", "post-failure"), ("closed-form", "post-failure")):
        with pytest.raises(lsc.SceneError, match=reason):
            lsc.solve(post_failure({"stiffness": K2}), method=method)


def test_post_failure_sweep_matches_single_solves():
    scene = post_failure(PF_DOWN, v1=5.0, v2=0.0, loading=PF_LOADING, failure=18000.0)
    speeds = [1.5, 5.0, 6.0]
    s = lsc.sweep(scene, {"vehicles.0.speed": speeds})  # (1.5 m/s stops short of D_f)
    assert s.method == "exact" and list(s.status) == ["ok"] * 3
    for j, v in enumerate(speeds):
        r = lsc.solve(lsc.Scene.load(scene).with_values({"vehicles.0.speed": v}), method="exact")
        for name in ("failure_time", "max_deformation", "delta_v"):
            np.testing.assert_allclose(s.metrics[name][j], getattr(r, name), rtol=1e-12)
    assert np.isnan(s.metrics["failure_time"][0, 0]) and np.all(s.metrics["failure_time"][1:] > 0)
    # a loading scale moves the failure point: each member is re-loaded, not rescaled
    t = lsc.sweep(scene, {"contacts.0.loading.scale": [0.9, 1.1]})
    for j, c in enumerate((0.9, 1.1)):
        r = lsc.solve(lsc.Scene.load(scene).with_values({"contacts.0.loading.scale": c}))
        np.testing.assert_allclose(t.metrics["max_deformation"][j], r.max_deformation, rtol=1e-12)


def test_post_failure_diffrax_batch_reports_the_failure_time():
    pytest.importorskip("diffrax")
    scene = post_failure(PF_DOWN, v1=5.0, v2=0.0, loading=PF_LOADING, failure=18000.0)
    speeds = [2.0, 5.0, 6.0]
    s = lsc.sweep(scene, {"vehicles.0.speed": speeds}, method="diffrax", rtol=1e-12)
    for j, v in enumerate(speeds):
        r = lsc.solve(lsc.Scene.load(scene).with_values({"vehicles.0.speed": v}), method="exact")
        np.testing.assert_allclose(s.metrics["failure_time"][j], r.failure_time, rtol=1e-9)
        np.testing.assert_allclose(s.metrics["max_deformation"][j], r.max_deformation, rtol=1e-9)


@pytest.mark.parametrize("post, path", [
    ({"table": [[0, 1000], [0, 2000]]}, "contacts[0].failure.post_failure.table"),
    ({"table": [[0, 1000], [0.1, -5]]}, "contacts[0].failure.post_failure.table"),
    ({"table": [[0.1, 1000], [0.2, 2000]]}, "contacts[0].failure.post_failure.table"),
    ({"stiffness": -1}, "contacts[0].failure.post_failure.stiffness"),
    ({"tabel": [[0, 0], [1, 1]]}, "contacts[0].failure.post_failure.tabel"),
])
def test_post_failure_bad_curve_is_a_scene_error_with_its_path(post, path):
    with pytest.raises(lsc.SceneError) as err:
        lsc.Scene.load(post_failure(post))
    assert err.value.path == path


def test_post_failure_loader_rules():
    # only the IF-D law has a loading curve to continue
    kelvin = post_failure()
    kelvin["contacts"][0] = {"law": "kelvin", "stiffness": K1, "restitution": 0.4,
                             "failure": {"force": FF, "post_failure": PF_LINE}}
    with pytest.raises(lsc.SceneError, match="IF-D") as err:
        lsc.Scene.load(kelvin)
    assert err.value.path == "contacts[0].failure.post_failure"
    # a loading curve that starts at or above the failure force fails at first touch
    with pytest.raises(lsc.SceneError, match="first touch"):
        lsc.Scene.load(post_failure(loading={"table": [[0, 30000], [1, 40000]]}))
    # a loading curve that never reaches the failure force never uses the post-failure curve
    low = post_failure(loading={"table": [[0, 0], [0.5, 15000]]}, v1=2.0)
    model = HybridModel(lsc.Scene.load(low))
    assert model.laws[0].loading.d.size == 2 and not np.isfinite(model.params["contacts"][0]["dfail"])
    r = lsc.solve(low, method="exact")
    assert not r.failed[0]


def test_spliced_curve_methods_on_a_step():
    from lsc.curves import Curve

    c, Df = Curve.linear(K1).splice(FF, Curve.table([[0, F0], [1, F0 + K2]]))
    assert Df == pytest.approx(0.1, rel=1e-15) and c.steps and not c.extends
    np.testing.assert_allclose(c.force([0.05, Df, 0.3, 1.1]), [1e4, F0, F0 + 0.2 * K2, F0 + K2])
    assert np.isnan(c.force(1.2))
    np.testing.assert_allclose(c.energy([Df, 0.3]), [1000.0, 1000.0 + 0.2 * F0 + 0.02 * K2])
    assert c.deformation_at(15000.0) == pytest.approx(0.075)   # on the virgin line
    assert c.deformation_at(FF) == pytest.approx(Df)
    assert c.f_top == F0 + K2
    d, f, s, e = c.pieces()  # the step's zero-width segment is left out
    np.testing.assert_allclose(d, [0, Df, 1 + Df])
    np.testing.assert_allclose(f, [0, F0, F0 + K2])
    np.testing.assert_allclose(s[:2], [K1, K2])
    np.testing.assert_allclose(e, [0, 1000.0, 1000.0 + F0 + 0.5 * K2])
    assert c.scaled(2.0).steps and c.scaled(2.0).force(0.3) == pytest.approx(2 * c.force(0.3))
    with pytest.raises(ValueError, match="series"):
        Curve.series(c, Curve.linear(K1))
    with pytest.raises(ValueError, match="strictly increasing"):
        Curve([0, 1, 1, 2], [0, 1, 2, 3])   # only a splice makes a step
    up, _ = Curve.linear(K1).splice(FF, Curve.linear(K2))
    assert up.extends and up.force(0.2) == pytest.approx(K2 * 0.1)
    never, d_inf = Curve.table([[0, 0], [1, 100]]).splice(FF, Curve.linear(K2))
    assert not never.steps and d_inf == np.inf


# ------------------------------------------------------------------ chains
def chain(gap2=0.0, e=1.0, v0=2.0, masses=(1200.0, 1200.0, 1200.0), k=1.0e5):
    """Three cars, the rear one at ``v0``; the second contact open by ``gap2``."""
    return vehicle_chain(masses, (v0, 0.0, 0.0),
                         [{"loading": {"stiffness": k}, "unloading": {"restitution": e}},
                          {"loading": {"stiffness": k}, "unloading": {"restitution": e},
                           "gap": gap2}])


def test_three_car_chain_momentum_and_event_order():
    r = lsc.solve(chain(gap2=0.05, e=0.6, masses=(1500.0, 1100.0, 1300.0)), method="scipy",
                  rtol=1e-12)
    m = np.array([1500.0, 1100.0, 1300.0])
    p0 = m @ np.array([2.0, 0.0, 0.0])
    assert abs(m @ r.v_final - p0) <= 1e-12 * p0
    assert np.max(np.abs(r.v @ m - p0)) <= 1e-11 * p0
    first = {k: min(ev.time for ev in r.events if ev.kind == "contact" and ev.index == k)
             for k in (0, 1)}
    assert first[0] < first[1], "contact 1 closes before contact 2"


def test_elastic_chain_passes_the_speed_down_exactly_when_contacts_do_not_overlap():
    T = np.pi * np.sqrt(600.0 / 1.0e5)  # elastic pulse of one equal-mass pair
    gap = 2.0 * T * 1.5  # the middle car covers it at 2 m/s after the first pulse
    r = lsc.solve(chain(gap2=gap), method="scipy", rtol=1e-12)
    assert r.v_final == pytest.approx([0.0, 0.0, 2.0], abs=1e-9)


def test_elastic_chain_with_overlapping_contacts_does_not():
    r = lsc.solve(chain(gap2=0.0), method="scipy", rtol=1e-12)
    m = 1200.0
    assert m * np.sum(r.v_final) == pytest.approx(m * 2.0, rel=1e-12)  # momentum still
    spread = np.max(np.abs(r.v_final - [0.0, 0.0, 2.0]))
    assert spread > 0.05, f"overlapping contacts share the impulse (off by {spread:.3f} m/s)"


def test_chain_contacts_close_again_and_reload():
    # a light middle car between two heavy ones rattles: contacts close more than once
    r = lsc.solve(chain(gap2=0.0, e=0.5, masses=(2000.0, 300.0, 2000.0)), method="scipy",
                  rtol=1e-11)
    kinds = [ev.kind for ev in r.events]
    assert "reload_past_max" in kinds
    m = np.array([2000.0, 300.0, 2000.0])
    assert abs(m @ r.v_final - 4000.0) <= 1e-12 * 4000.0
    ke0 = 0.5 * 2000.0 * 4.0
    ke1 = 0.5 * m @ r.v_final**2
    lost = np.sum(r.energy_absorbed - r.energy_returned)
    assert ke0 - ke1 == pytest.approx(lost, rel=1e-8)


# ------------------------------------------------------------------ only what a scene names
def test_a_scene_without_an_effect_evaluates_no_term_of_it(monkeypatch):
    from lsc import effects

    calls = []
    for name in ("accel", "events"):
        orig = getattr(effects.BrakeEffect, name)
        monkeypatch.setattr(effects.BrakeEffect, name,
                            staticmethod(lambda *a, _o=orig, _n=name: calls.append(_n) or _o(*a)))
    plain = braked(2.0)
    model = HybridModel(lsc.Scene.load(plain))
    assert model.brakes == [] and model.failures == [] and model.work == []
    assert len(model.events) == 3 and model.n_state == 4
    lsc.solve(plain, method="scipy")
    assert calls == []
    lsc.solve(braked(2.0, mu1=0.7), method="scipy")
    assert "accel" in calls and "events" in calls


def test_law_numbers_trace_under_jax_as_they_compute_on_numpy():
    """A law builds its model numbers from its keys with array code: jitted with JAX it gives
    the NumPy numbers (targets converted by a root find excepted: they are NumPy only)."""
    jax = pytest.importorskip("jax")
    import jax.numpy as jnp

    from lsc.laws import make_law

    jax.config.update("jax_enable_x64", True)  # as the JAX backend does

    cases = [(lsc.Scene.load({"vehicles": [{"mass": M1, "speed": 3.0}, {"mass": M2, "speed": 0}],
                              "contacts": [{"loading": {"table": [[0, 0], [0.1, 1e4], [0.3, 9e4]],
                                                        "scale": 2.0},
                                            "unloading": {"restitution": 0.4}}]}),
              {"loading.scale": [1.0, 3.0], "unloading.restitution": [0.1, 0.7]}),
             (lsc.Scene.load(damped("kelvin", stiffness=2.0e5, damping=4000.0)),
              {"stiffness": [1e5, 3e5], "damping": [1e3, 8e3]}),
             (lsc.Scene.load(damped("hunt-crossley", stiffness=2.0e5, exponent=1.5, damping=0.2)),
              {"exponent": [1.0, 1.2], "damping": [0.1, 0.4]}),
             (lsc.Scene.load(damped("brach", stiffness=2.0e5, restitution=0.5, damping=1e4)),
              {"restitution": [0.3, 0.8], "damping": [0.0, 2e4]})]
    mu = np.array([MU, 2 * MU])
    for scene, changes in cases:
        law = make_law(scene.contacts[0], MU)
        changes = {k: np.asarray(v) for k, v in changes.items()}
        on_numpy = law.numbers(changes, mu, np)
        traced = jax.jit(lambda c, m: law.numbers(c, m, jnp))(changes, mu)
        for name, value in on_numpy.items():
            np.testing.assert_allclose(np.asarray(traced[name]), value, rtol=1e-15, atol=0,
                                       err_msg=f"{law.name} {name}")


def test_a_damping_law_key_swept_with_units_is_its_declared_unit():
    """A swept damping key given with units is converted by the unit its law declares: each
    member solves as the scene with that damping in scene units."""
    base = damped("kelvin", stiffness=2.0e5, damping=4000.0)
    s = lsc.sweep(base, {"contacts.0.damping": ["2 kN*s/m", "300 lbf*s/ft"]}, method="scipy")
    for j, c in enumerate([2000.0, 300 * 4.4482216152605 / 0.3048]):
        r = lsc.solve(damped("kelvin", stiffness=2.0e5, damping=c), method="scipy")
        np.testing.assert_allclose(s.metrics["delta_v"][j], r.delta_v, rtol=1e-12)
