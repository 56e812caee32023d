"""Near-plastic chains that exact-chain could not finish (issue 13, item 5; bench_chain.py
--chatter): each found by the benchmark's random near-plastic chains, each a defect of its own.

- A soft pair beside an unloading line 1e18 times stiffer (contact 1 open between them): one
  ``eigh`` of the whole chain lost the soft pair's mode (its vector a zero column once projected
  off the rigid modes), so the segment's motion froze that pair's relative motion, an opening
  contact was moved closing, and it touched for 8.9e-17 s (the impact record refused it as too
  short for the clock). The modes are now solved one coupled block at a time.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

import lsc
from lsc.solvers.exact_chain._modes import Shape, deformation_map

#: bench_chain.py --chatter 80 --seed 7, chain 76: contact 2 (a table, e = 9e-8) locks, then
#: unlocks onto an 8.4e21 lbf/ft line while contact 0 (8881 lbf/ft) still loads.
SEED7_CHAIN76 = {
    "units": "US",
    "contacts": [
        {"loading": {"stiffness": 8881.2346182293},
         "unloading": {"restitution": 0.004176436473657308}, "gap": 0.0},
        {"loading": {"table": [[0.0, 0.0], [0.0011113512521411313, 31259.310453829734],
                               [0.0022227025042822627, 31259.310453829734],
                               [1000.0, 281273034673.89685]]},
         "unloading": {"restitution": 0.012361672932661168}, "gap": 0.0},
        {"loading": {"table": [[0.0, 0.0], [0.25909502655756345, 17391737.741213426],
                               [0.5181900531151269, 17391737.741213426],
                               [1000.0, 671266777427.8784]]},
         "unloading": {"restitution": 8.952366654133816e-08}, "gap": 0.0}],
    "vehicles": [{"mass": 11.801185282116077, "speed": 102.29892160686714},
                 {"mass": 260.5661636334843, "speed": 102.29548553524337},
                 {"mass": 221.83413263697787, "speed": 96.12099195024933},
                 {"mass": 25.469144266250705, "speed": 57.94899651286394}]}


def test_a_soft_pair_beside_a_far_stiffer_line_keeps_its_mode():
    # (the segment that failed: contact 0 loading, contact 1 open, contact 2 on its line)
    m = np.array([v["mass"] for v in SEED7_CHAIN76["vehicles"]])
    slope = np.array([8881.2346182293, 0.0, 8.375450562139213e21])
    shape = Shape(m, slope, -deformation_map(m.size).T)
    Q = np.sqrt(m)[:, None] * shape.T            # (the orthonormal eigenvectors)
    assert np.allclose(Q.T @ Q, np.eye(m.size), rtol=0, atol=1e-12)
    # each block's A = M^-1/2 Cᵀ S C M^-1/2 rebuilt from its modes, to rounding of that block
    scaled = deformation_map(m.size) / np.sqrt(m)[None, :]
    for rows, k in (([0, 1], 0), ([2, 3], 2)):
        A = slope[k] * np.outer(scaled[k, rows], scaled[k, rows])
        rebuilt = (Q[rows] * shape.modes.kappa) @ Q[rows].T
        assert np.max(np.abs(rebuilt - A)) <= 1e-13 * np.max(np.abs(A))


def test_a_soft_pair_beside_a_far_stiffer_line_finishes_as_scipy():
    exact = lsc.solve(SEED7_CHAIN76, method="exact-chain")
    ref = lsc.solve(SEED7_CHAIN76, method="scipy", rtol=1e-13, atol=1e-16)
    # (no contact touches for less than the clock resolves; the first impact as SciPy's)
    assert all(i.t_end - i.t_start > 1e-9 for i in exact.impacts)
    for a, b in zip(exact.impacts[:3], ref.impacts[:3]):   # (all three at t = 0)
        assert (a.contact, a.t_start) == (b.contact, b.t_start)
    a, b = exact.impacts[:3], ref.impacts[:3]
    assert max(abs(a[k].t_end - b[k].t_end) for k in (0, 1)) <= 1e-9 * exact.duration
    # (contact 2 leaves its line, 1.8e-16 ft wide, at once; SciPy follows its quarter period)
    assert 0 < b[2].t_end - a[2].t_end <= 1e-10
    for name in ("peak_force", "peak_acceleration", "duration"):
        a, b = np.asarray(getattr(exact, name)), np.asarray(getattr(ref, name))
        assert np.max(np.abs(a - b)) <= 1e-11 * np.max(np.abs(b)), name
    # ΔV within the rebound exact-chain drops on contact 2's line, narrower than it resolves
    # at its start (e = 9e-8: e times the closing speed, 38 ft/s)
    e2, closing2 = 8.952366654133816e-08, 96.12099195024933 - 57.94899651286394
    assert np.max(np.abs(exact.delta_v - ref.delta_v)) <= 2 * e2 * closing2


#: bench_chain.py --chatter 60 --seed 5, chain 46: contact 1 (e = 8.6e-6) locks, contact 0 (a
#: table, e = 1.3e-7) reaches its maximum 0.27 s later on a line 1.3e-14 ft wide; contact 1's
#: release on its own line, 1.4e-13 ft wide, kicks car 1 back at 3.1e-6 ft/s onto contact 0.
SEED5_CHAIN46 = {
    "units": "US",
    "contacts": [
        {"loading": {"table": [[0.0, 0.0], [0.3819145534582387, 77.7936027722513],
                               [0.7638291069164774, 77.7936027722513],
                               [1000.0, 2037015.1678879296]]},
         "unloading": {"restitution": 1.3344309336111413e-07}, "gap": 0.006674207250984348},
        {"loading": {"stiffness": 239771011.5406966},
         "unloading": {"restitution": 8.643541087036972e-06}, "gap": 0.006674207250984348}],
    "vehicles": [{"mass": 21.578787168416802, "speed": 61.16633923195393},
                 {"mass": 377.6877164230082, "speed": 54.811778467873204},
                 {"mass": 22.59831112662235, "speed": 48.45721770379248}]}


def test_a_pair_closing_faster_than_its_narrow_line_returns_goes_over_its_top():
    # The pair closes again at W = 3.1e-6 ft/s onto its rebound line (e² E_c = 8e-12 ft lbf of
    # elastic energy, 1.3e-14 ft wide: narrower than exact-chain resolves at its start); its
    # closing energy μ W² / 2 = 1e-10 ft lbf is 12 times that: it reloads past D_max, where
    # F_max stops it in μ W / F_max. It looped closing and separating at one instant to the
    # event limit (the line was left apart at once).
    m = np.array([v["mass"] for v in SEED5_CHAIN46["vehicles"]])
    exact = lsc.solve(SEED5_CHAIN46, method="exact-chain")
    kinds = [(e.kind, e.index) for e in exact.events]
    assert ("reload_past_max", 0) in kinds
    again = exact.impacts[2]
    assert again.contact == 0 and exact.impacts[0].contact == 0
    first = exact.impacts[0]
    mu = m[0] * m[1] / (m[0] + m[1])
    W, F_max = again.closing_speed, first.peak_force
    line = 2 * 1.3344309336111413e-07 ** 2 * exact.impacts[0].max_deformation  # (≥ its width)
    assert mu * W ** 2 > F_max * line
    assert again.t_end - again.t_start == pytest.approx(mu * W / F_max, rel=1e-3)
    # its peak force where the closing energy left over the line's, μ W² / 2 - e² E_c, stops it
    # on the loading line past D_max (F_max, slope k): F_max δ + k δ² / 2 of it, F_max + k δ
    # (it read 2227 lbf: the rebound line's slope times the positions' rounding); the front
    # car's acceleration that force over its mass
    (_, _), (d1, f1), (d2, f2), (d3, f3) = SEED5_CHAIN46["contacts"][0]["loading"]["table"]
    D_max, k = first.max_deformation, (f3 - f2) / (d3 - d2)
    E_c = 0.5 * f1 * d1 + f1 * (d2 - d1) + 0.5 * (f2 + F_max) * (D_max - d2)
    left = 0.5 * mu * W ** 2 - 1.3344309336111413e-07 ** 2 * E_c
    delta = 2 * left / (F_max + math.sqrt(F_max ** 2 + 2 * k * left))
    assert again.peak_force == pytest.approx(F_max + k * delta, rel=1e-13)
    assert again.peak_acceleration[0] == pytest.approx(-again.peak_force / m[0], rel=1e-12)
    t, F = np.asarray(exact.t), np.asarray(exact.force)[:, 0]   # (the series: none above it)
    assert np.all(F[(t >= again.t_start) & (t <= again.t_end)] <= again.peak_force)
    assert not any("rebound line" in w for w in exact.warnings)
    # against SciPy at rtol 1e-12 (which follows the line as a spring: its bounce): the first
    # impacts alike; the final speeds within twice that closing speed (SciPy returns it, the
    # reload keeps it, its new rebound below resolution dropped)
    ref = lsc.solve(SEED5_CHAIN46, method="scipy", rtol=1e-12)
    assert np.max(np.abs(exact.delta_v - ref.delta_v)) <= 2 * W
    assert np.max(np.abs(exact.v_final - ref.v_final)) <= 2 * W
    speeds = np.array([v["speed"] for v in SEED5_CHAIN46["vehicles"]])
    assert abs(m @ exact.v_final - m @ speeds) <= 1e-14 * m @ exact.v_final


def test_a_pair_closing_slower_than_its_narrow_line_returns_bounces_elastically():
    # Chain 46 with a front car of 5 slugs: contact 1's release kicks car 1 back at 7.1e-7
    # ft/s, below what contact 0's line returns (μ W² < s wl²): the line, a spring of slope
    # s = F_max² / (2 e² E_c), returns the pair from its foot after π/ω with the speed it came
    # in, reversed. It looped closing and separating at one instant to the event limit.
    scene = copy.deepcopy(SEED5_CHAIN46)
    scene["vehicles"][2]["mass"] = 5.0
    exact = lsc.solve(scene, method="exact-chain")
    bounce = exact.impacts[2]
    assert bounce.contact == 0 and exact.impacts[0].contact == 0
    assert bounce.separation_speed == pytest.approx(bounce.closing_speed, rel=1e-9)
    (_, _), (d1, f1), (d2, f2), (d3, f3) = scene["contacts"][0]["loading"]["table"]
    e = scene["contacts"][0]["unloading"]["restitution"]
    D_max = exact.impacts[0].max_deformation
    F_max = f2 + (f3 - f2) / (d3 - d2) * (D_max - d2)
    E_c = 0.5 * f1 * d1 + f1 * (d2 - d1) + 0.5 * (f2 + F_max) * (D_max - d2)
    m = np.array([v["mass"] for v in scene["vehicles"]])
    mu = m[0] * m[1] / (m[0] + m[1])
    omega = math.sqrt(F_max ** 2 / (2 * e * e * E_c) / mu)
    assert mu * bounce.closing_speed ** 2 < F_max * 2 * e * e * E_c / F_max   # (μW² < s wl²)
    # (contact 1 open all along: the pair alone; π/ω to the clock's ulps at 0.27 s)
    assert bounce.t_end - bounce.t_start == pytest.approx(math.pi / omega, rel=1e-8)
    # its peak force the spring's, sqrt(s μ) W = μ ω W, and each car's acceleration that force
    # over its mass (they read 1427.66 lbf, above F_max, and -66.2 ft/s², the line's slope
    # times the positions' rounding at the bounce's two ends, where the line's force is zero)
    assert bounce.peak_force == pytest.approx(mu * omega * bounce.closing_speed, rel=1e-9)
    assert np.allclose(bounce.peak_acceleration, (-bounce.peak_force / m[0],
                                                  bounce.peak_force / m[1]), rtol=1e-9, atol=0)
    assert not any("rebound line" in w for w in exact.warnings)
    # the sampled series too: zero at the bounce's two ends (the foot), never above its peak
    t, F = np.asarray(exact.t), np.asarray(exact.force)[:, 0]
    on = (t >= bounce.t_start) & (t <= bounce.t_end)
    assert np.all(F[(t == bounce.t_start) | (t == bounce.t_end)] == 0.0)
    assert np.all(F[on] <= bounce.peak_force)
    speeds = np.array([v["speed"] for v in scene["vehicles"]])
    assert abs(m @ exact.v_final - m @ speeds) <= 1e-14 * m @ exact.v_final
    # (SciPy at rtol 1e-12 follows contact 0's first rebound instead, which exact-chain drops:
    # the pair's final speeds within that rebound's speed, twice the bounce's; the front car's
    # follow contact 1's 1.1e-13 ft wide line, which SciPy's positions resolve to a few %)
    ref = lsc.solve(scene, method="scipy", rtol=1e-12)
    assert np.max(np.abs(exact.v_final - ref.v_final)[:2]) <= 4 * bounce.closing_speed


#: bench_chain.py --chatter 80 --seed 7, chain 20: three near-plastic contacts (e = 1e-6) of
#: a rattling chain; at 0.069 s contact 2's rebound kicks car 2 back onto contact 1's line.
SEED7_CHAIN20 = {
    "units": "US",
    "contacts": [
        {"loading": {"table": [[0.0, 0.0], [0.03708993127960312, 1481.3203034352491],
                               [0.07417986255920624, 1481.3203034352491],
                               [1000.0, 399387582.1648397]]},
         "unloading": {"restitution": 1e-06}, "gap": 0.0},
        {"loading": {"table": [[0.0, 0.0], [0.021519955496540094, 3339116.713034631],
                               [0.04303991099308019, 3339116.713034631],
                               [1000.0, 1551640708242.0737]]},
         "unloading": {"restitution": 1e-06}, "gap": 0.0},
        {"loading": {"stiffness": 15515.155702850656}, "unloading": {"restitution": 1e-06},
         "gap": 0.0}],
    "vehicles": [{"mass": 26.364287516509584, "speed": 0.20140908570114824},
                 {"mass": 201.24824582290552, "speed": 0.0},
                 {"mass": 23.67012749462402, "speed": 0.0},
                 {"mass": 13.184662600287389, "speed": 0.0}]}


def test_a_recontact_shorter_than_the_clock_resolves_is_refused_at_once():
    # Contact 1 closes again at 7.7e-10 ft/s onto its line (1.6e-19 ft wide, 1.6e20 lbf/ft),
    # faster than the line returns: it reloads, F_max (24 lbf) stops it in 6.8e-10 s, which
    # the clock at t = 0.069 s resolves only to 2e-8: refused, as SciPy's bounce of 1.2e-9 s
    # is; it looped closing and separating at one instant to the event limit.
    with pytest.raises(lsc.SimulationError) as info:
        lsc.solve(SEED7_CHAIN20, method="exact-chain", max_events=2000)
    message = str(info.value)
    assert message.startswith("contact 1: the impact starts at t = 0.0690244 s and lasts 6.75e-10")
    assert "too coarse to represent the impact" in message and "re-contact" in message
