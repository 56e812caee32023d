"""lsc.analysis.monte_carlo: reproducible sampling and percentiles that converge."""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

import lsc
from helpers import paper_scene
from lsc.analysis import monte_carlo, sample

G = 32.2
M = 3500 / G


def test_reproducible_for_a_seed():
    d = {"vehicles.0.speed": {"uniform": [4, 8]},
         "contacts.0.unloading.restitution": {"triangular": [0.2, 0.4, 0.7]}}
    a = monte_carlo(paper_scene(), d, 2000, seed=7)
    b = monte_carlo(paper_scene(), d, 2000, seed=7)
    c = monte_carlo(paper_scene(), d, 2000, seed=8)
    for p in d:
        assert np.array_equal(a.samples[p], b.samples[p])
        assert not np.array_equal(a.samples[p], c.samples[p])
    for name in a.percentiles:
        assert np.array_equal(a.percentiles[name], b.percentiles[name])
    assert np.array_equal(a.sweep.delta_v, b.sweep.delta_v)


def test_converges_to_the_analytic_distribution():
    """v0 ~ U(4, 8) ft/s, e = 0.4, m1 = m2: ΔV2 = (1+e) v0/2 ~ U(2.8, 5.6), F = v0 √(kμ) uniform,
    duration constant; the sample percentiles approach the exact ones within sampling error."""
    n = 40_000
    mc = monte_carlo(paper_scene(), {"vehicles.0.speed": {"uniform": ["4 ft/s", "8 ft/s"]}}, n,
                     seed=1, percentiles=(5, 25, 50, 75, 95))
    assert mc.sweep.method == "closed-form"
    assert mc.ok.all()
    p = np.array(mc.q) / 100
    se = np.sqrt(p * (1 - p) / n)  # standard error of a uniform's p-quantile, per unit range
    dv2 = 2.8 + 2.8 * p
    assert np.all(np.abs(mc.percentiles["delta_v"][:, 1] - dv2) < 5 * se * 2.8)
    assert np.all(np.abs(mc.percentiles["delta_v"][:, 0] + dv2[::-1]) < 5 * se * 2.8)
    scale = np.sqrt(24000 * M / 2)
    force = scale * (4 + 4 * p)
    assert np.all(np.abs(mc.percentiles["peak_force"][:, 0] - force) < 5 * se * 4 * scale)
    g2 = force / M / G
    assert np.all(np.abs(mc.percentiles["peak_acceleration_g"][:, 1] - g2) < 5 * se * 4 * scale / M / G)
    w = np.sqrt(24000 / (M / 2))
    assert mc.percentiles["duration"] == pytest.approx(np.full(5, np.pi / (2 * w) * 1.4), rel=1e-12)


def test_distribution_kinds_and_units():
    sc = paper_scene()
    n = 50_000
    s = sample(sc, {"vehicles.0.speed": {"normal": ["10 ft/s", "1 ft/s"]},
                    "vehicles.1.weight": {"triangular": [3000, 3300, 3900]},
                    "contacts.0.unloading.restitution": {"normal": [0.5, 0.3], "min": 0, "max": 1},
                    "contacts.0.loading.stiffness": {"choice": ["20000 lbf/ft", 24000, "2 kN/mm"]},
                    "vehicles.0.weight": [3400, 3500]},
               n, seed=3)
    assert s["vehicles.0.speed"].mean() == pytest.approx(10, abs=0.03)
    assert s["vehicles.0.speed"].std() == pytest.approx(1, rel=0.02)
    assert s["vehicles.1.weight"].mean() == pytest.approx((3000 + 3300 + 3900) / 3, abs=5)
    e = s["contacts.0.unloading.restitution"]
    assert e.min() >= 0 and e.max() <= 1 and e.size == n
    ks = np.unique(s["contacts.0.loading.stiffness"])
    assert ks == pytest.approx([20000, 24000, 2e6 / 4.4482216152605 * 0.3048])
    assert set(np.unique(s["vehicles.0.weight"])) == {3400.0, 3500.0}
    si = sample({"vehicles": [{"mass": 1000, "speed": 3}, {"mass": 1000, "speed": 0}],
                 "contacts": [{"loading": {"stiffness": 1e5}, "unloading": {"restitution": 0.5}}]},
                {"vehicles.0.speed": {"uniform": ["10 km/h", "20 km/h"]}}, 1000, seed=0)
    assert si["vehicles.0.speed"].min() >= 10 / 3.6 and si["vehicles.0.speed"].max() <= 20 / 3.6


def test_function_of_sampled_values_and_nested_tables():
    """Restitution as a function of closing speed (the Cipriani et al. kind of relation)."""
    def e_of_v(s):
        return np.clip(0.6 - 0.03 * s["vehicles.0.speed"], 0.0, 1.0)

    def noisy(s, rng):
        return e_of_v(s) + rng.normal(0, 0.01, s["vehicles.0.speed"].size)

    d = {"vehicles": {"0": {"speed": {"uniform": [2, 10]}}},       # TOML dotted keys, unquoted
         "contacts.0.unloading.restitution": {"function": e_of_v}}
    mc = monte_carlo(paper_scene(), d, 500, seed=2)
    v = mc.samples["vehicles.0.speed"]
    assert list(mc.samples) == ["vehicles.0.speed", "contacts.0.unloading.restitution"]
    assert mc.samples["contacts.0.unloading.restitution"] == pytest.approx(0.6 - 0.03 * v)
    assert mc.sweep.delta_v[:, 1] == pytest.approx((1 + 0.6 - 0.03 * v) * v / 2, rel=1e-12)
    s1 = sample(paper_scene(), {"vehicles.0.speed": {"uniform": [2, 10]},
                                "contacts.0.unloading.restitution": {"function": noisy}}, 100, seed=4)
    s2 = sample(paper_scene(), {"vehicles.0.speed": {"uniform": [2, 10]},
                                "contacts.0.unloading.restitution": {"function": noisy}}, 100, seed=4)
    assert np.array_equal(s1["contacts.0.unloading.restitution"], s2["contacts.0.unloading.restitution"])


def test_failed_members_are_reported_not_summarised():
    mc = monte_carlo(paper_scene(), {"contacts.0.unloading.restitution": {"normal": [0.9, 0.2]}},
                     400, seed=5)
    bad = ~mc.ok
    assert bad.any() and mc.ok.any()
    e = mc.samples["contacts.0.unloading.restitution"]
    assert np.array_equal(bad, (e < 0) | (e > 1))
    good = e[mc.ok]
    assert mc.percentiles["delta_v"][:, 1] == pytest.approx(np.percentile((1 + good) * 5, [5, 50, 95]),
                                                            rel=1e-12)
    assert "failed members" in mc.summary()


def test_piecewise_linear_scene_and_histogram(tmp_path):
    sc = {"units": "US", "name": "table",
          "vehicles": [{"name": "bullet", "weight": 4000, "speed": 6}, {"name": "target", "weight": 3000, "speed": 0}],
          "contacts": [{"loading": {"table": [[0, 0], [0.02, 400], [0.05, 3000], [0.3, 40000]]},
                        "unloading": {"restitution": 0.4}}]}
    mc = monte_carlo(sc, {"vehicles.0.speed": {"uniform": [3, 9]},
                          "contacts.0.loading.scale": {"normal": [1.0, 0.05], "min": 0.8, "max": 1.2}},
                     60, seed=0, progress=False)
    assert mc.ok.all()
    r = lsc.solve(lsc.Scene.load(sc).with_values({p: v[7] for p, v in mc.samples.items()}))
    assert mc.sweep.delta_v[7] == pytest.approx(r.delta_v, rel=1e-12)
    fig = mc.histogram("peak_acceleration_g")
    fig.savefig(tmp_path / "h.png")
    assert (tmp_path / "h.png").stat().st_size > 1000
    assert "target" in fig.axes[0].get_xlabel()
    fig2 = mc.histogram("peak_force", bins=10)
    assert "contact 0" in fig2.axes[0].get_xlabel()
    text = mc.summary()
    assert "p50" in text and "peak force contact 0" in text


@pytest.mark.parametrize("d, match", [
    ({"vehicles.0.speed": {"gauss": [1, 2]}}, "exactly one"),
    ({"vehicles.0.sped": {"uniform": [1, 2]}}, "unknown key"),
    ({"vehicles.0.speed": {"normal": [1]}}, "takes 2 values"),
    ({"vehicles.0.speed": {"normal": [5, -1]}}, "standard deviation"),
    ({"vehicles.0.speed": {"uniform": [5, 1]}}, "lo <= hi"),
    ({"vehicles.0.speed": {"triangular": [1, 9, 5]}}, "mode"),
    ({"vehicles.0.speed": {"choice": []}}, "non-empty"),
    ({"vehicles.0.speed": {"uniform": [1, 5], "max": 3}}, "unknown key"),
    ({"vehicles.0.speed": {"function": 3}}, "callable"),
    ({"vehicles.0.speed": {"function": lambda s: [1, 2, 3]}}, "must return"),
    ({"vehicles.0.speed": 5}, "a distribution is"),
    ({}, "non-empty dict"),
])
def test_bad_distributions(d, match):
    with pytest.raises(lsc.SceneError, match=match):
        sample(paper_scene(), d, 10, seed=0)


def test_bad_n_and_percentiles():
    with pytest.raises(lsc.SceneError, match="positive integer"):
        sample(paper_scene(), {"vehicles.0.speed": {"uniform": [1, 5]}}, 0)
    with pytest.raises(lsc.SceneError, match="percentiles"):
        monte_carlo(paper_scene(), {"vehicles.0.speed": {"uniform": [1, 5]}}, 10, percentiles=(5, 150))


@pytest.mark.parametrize("mean, sd, lo, hi", [(0.5, 0.3, 0.0, 1.0), (0.0, 1.0, 3.0, 4.0),
                                              (10.0, 2.0, -np.inf, 9.0), (0.0, 1.0, -5.5, -5.0)])
def test_truncated_normal_moments(mean, sd, lo, hi):
    from scipy.stats import truncnorm
    a, b = (lo - mean) / sd, (hi - mean) / sd
    spec = {"normal": [mean, sd]}
    if np.isfinite(lo):
        spec["min"] = lo
    spec["max"] = hi
    x = sample(paper_scene(), {"contacts.0.loading.scale": spec}, 40_000, seed=11)["contacts.0.loading.scale"]
    assert x.min() >= lo and x.max() <= hi
    m, v = truncnorm.stats(a, b, loc=mean, scale=sd, moments="mv")
    assert x.mean() == pytest.approx(m, abs=5 * np.sqrt(v / x.size))
    assert x.std() == pytest.approx(np.sqrt(v), rel=0.03)


def test_function_named_as_module_attribute(tmp_path, monkeypatch):
    """A TOML [uncertainty] table names its function as "module:name"."""
    (tmp_path / "restitution_model.py").write_text(
        "def e_of_speed(s):\n    return 0.7 - 0.05 * s['vehicles.0.speed']\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    s = sample(paper_scene(), {"vehicles.0.speed": {"uniform": [2, 8]},
                               "contacts.0.unloading.restitution": {"function": "restitution_model:e_of_speed"}},
               50, seed=0)
    assert s["contacts.0.unloading.restitution"] == pytest.approx(0.7 - 0.05 * s["vehicles.0.speed"])
    with pytest.raises(lsc.SceneError, match="cannot import"):
        sample(paper_scene(), {"contacts.0.unloading.restitution": {"function": "no_such_mod:f"}}, 5)


UNIFORM = {"vehicles.0.speed": {"uniform": [5, 10]}}


@pytest.mark.parametrize("seed", ["x", -1, 1.5, True])
def test_bad_seed_is_refused(seed):
    with pytest.raises(lsc.SceneError) as e:
        monte_carlo(paper_scene(), UNIFORM, 10, seed=seed)
    assert str(e.value) == ("seed: the seed must be a whole number >= 0 (or None: a fresh one "
                            f"each run), got {seed!r}")


def test_too_many_samples_are_refused_up_front():
    with pytest.raises(lsc.SceneError) as e:
        monte_carlo(paper_scene(), UNIFORM, 10 ** 9, seed=0)
    assert str(e.value) == ("n: 1000000000 members are more than the 10000000 one study solves "
                            "(every member's metrics are held in memory at once): split it into "
                            "smaller ones")


def test_unknown_keyword_is_refused_by_name():
    with pytest.raises(lsc.SceneError) as e:
        monte_carlo(paper_scene(), UNIFORM, 10, sed=1)
    assert e.value.path == "sed"
    assert str(e.value).startswith("sed: monte_carlo() got an unknown keyword 'sed'; it accepts "
                                   "seed, method, progress, percentiles, metrics, out, overwrite, "
                                   "executor, task_size and the solver options ")


def test_bumper_failure_at_a_preloaded_tables_step_is_kept():
    # the scene: 6000 lbf at first touch over a 5000 lbf failure force, 0.5 ft apart;
    # every member fails when the gap closes, at 0.5 ft / closing speed (it used to be NaN)
    scene = {"units": "US", "vehicles": [{"weight": 3000, "speed": 10}, {"weight": 2500, "speed": 0}],
             "contacts": [{"loading": {"table": [[0, 6000], [0.5, 20000]]},
                           "unloading": {"restitution": 0.4}, "gap": 0.5,
                           "failure": {"force": 5000}}]}
    mc = monte_carlo(scene, {"vehicles.0.speed": {"uniform": [8, 12]}}, 50, seed=0)
    assert mc.sweep.method == "exact" and np.all(mc.sweep.ok)
    speeds = mc.samples["vehicles.0.speed"]
    np.testing.assert_allclose(mc.sweep.failure_time[:, 0], 0.5 / speeds, rtol=1e-14)


# --------------------------------------------------------------------------- designs, correlation
from scipy import stats  # noqa: E402

THREE = {"vehicles.0.speed": {"uniform": [4, 8]},
         "vehicles.1.weight": {"normal": [3500, 100]},
         "contacts.0.unloading.restitution": {"triangular": [0.2, 0.4, 0.7]}}
CDFS = {"vehicles.0.speed": stats.uniform(4, 4).cdf,
        "vehicles.1.weight": stats.norm(3500, 100).cdf,
        "contacts.0.unloading.restitution": stats.triang(0.4, loc=0.2, scale=0.5).cdf}


def test_random_sampling_is_todays_draws_bit_for_bit():
    """The default design is one PCG64 generator drawing the paths in the table's order, as
    before the designs existed: the same numbers as those draws written out here."""
    rng = np.random.default_rng(7)
    expected = {"vehicles.0.speed": rng.uniform(4, 8, 500),
                "vehicles.1.weight": rng.normal(3500, 100, 500),
                "contacts.0.unloading.restitution": rng.triangular(0.2, 0.4, 0.7, 500),
                "vehicles.0.weight": np.array([3000.0, 3500.0])[rng.integers(0, 2, 500)]}
    d = {**THREE, "vehicles.0.weight": {"choice": [3000, 3500]}}
    for got in (sample(paper_scene(), d, 500, seed=7),
                sample(paper_scene(), d, 500, seed=7, sampling="random"),
                monte_carlo(paper_scene(), d, 500, seed=7, sampling="random").samples):
        assert list(got) == list(expected)
        for path in expected:
            assert np.array_equal(got[path], expected[path])


@pytest.mark.parametrize("sampling", ["sobol", "lhs"])
def test_designs_put_one_member_in_each_equal_probability_stratum(sampling):
    """A Latin hypercube, and a scrambled Sobol' net of 2^m points, hold exactly one point in each
    of the n equal-probability intervals of every input: the inverse CDF keeps that, so each
    input's CDF values fall one per stratum (a random sample leaves many empty)."""
    n = 256
    s = sample(paper_scene(), THREE, n, seed=3, sampling=sampling)
    for path, cdf in CDFS.items():
        strata = np.floor(cdf(s[path]) * n).astype(int)
        assert np.array_equal(np.sort(strata), np.arange(n)), path
    assert np.array_equal(s["vehicles.0.speed"],
                          sample(paper_scene(), THREE, n, seed=3, sampling=sampling)["vehicles.0.speed"])
    assert not np.array_equal(s["vehicles.0.speed"],
                              sample(paper_scene(), THREE, n, seed=4, sampling=sampling)["vehicles.0.speed"])
    r = sample(paper_scene(), THREE, n, seed=3)
    assert len(np.unique(np.floor(CDFS["vehicles.0.speed"](r["vehicles.0.speed"]) * n))) < 0.7 * n


def test_sobol_monte_carlo_mean_delta_v_is_closer_than_sampling_error():
    """ΔV2 = (1+e) v0 m1/(m1+m2) = 0.7 v0 for equal masses, v0 ~ U(4, 8) ft/s: mean 4.2 ft/s.
    1024 Sobol' points get the mean to ~1e-6 (QMC error ~ 1/n); plain sampling's standard error
    is 0.7 * 4/√12/√1024 ≈ 0.025."""
    mc = monte_carlo(paper_scene(), {"vehicles.0.speed": {"uniform": [4, 8]}}, 1024, seed=0,
                     sampling="sobol")
    assert mc.sampling == "sobol" and "scrambled Sobol' points" in mc.summary()
    assert abs(np.mean(mc.sweep.delta_v[:, 1]) - 4.2) < 1e-4


def test_unknown_sampling_is_refused_by_name():
    with pytest.raises(lsc.SceneError) as e:
        monte_carlo(paper_scene(), UNIFORM, 16, seed=0, sampling="halton")
    assert str(e.value) == "sampling: the sampling design is one of random, sobol, lhs; got 'halton'"


def test_sobol_count_not_a_power_of_two_is_kept_with_a_warning():
    with pytest.warns(UserWarning, match=r"n = 100 is not a power of two: the first 100 points "
                                         r"of a scrambled Sobol' sequence are used as asked.*"
                                         r"use n = 64 or 128"):
        s = sample(paper_scene(), UNIFORM, 100, seed=0, sampling="sobol")
    assert s["vehicles.0.speed"].size == 100


RANKS = [[1, 0.6, -0.3], [0.6, 1, 0], [-0.3, 0, 1]]


@pytest.mark.parametrize("sampling", ["random", "sobol", "lhs"])
@pytest.mark.parametrize("form", ["matrix", "pairs"])
def test_correlated_inputs_have_the_requested_rank_correlation_and_their_marginals(sampling, form):
    """The Gaussian copula gives the requested Spearman matrix (within the sampling error,
    ~(1-ρ²)/√n ≈ 0.007 here) and leaves every marginal as specified (KS test)."""
    corr = RANKS if form == "matrix" else [
        ["vehicles.0.speed", "vehicles[1].weight", 0.6],
        ["contacts.0.unloading.restitution", "vehicles.0.speed", -0.3]]
    n = 16384
    s = sample(paper_scene(), {**THREE, "correlation": corr}, n, seed=11, sampling=sampling)
    rho = stats.spearmanr(np.column_stack([s[p] for p in THREE])).statistic
    np.testing.assert_allclose(rho, RANKS, atol=0.03)
    for path, cdf in CDFS.items():
        assert stats.kstest(s[path], cdf).pvalue > 0.01, path


def test_uncorrelated_inputs_stay_uncorrelated():
    s = sample(paper_scene(), THREE, 16384, seed=5, sampling="lhs")
    rho = stats.spearmanr(np.column_stack([s[p] for p in THREE])).statistic
    np.testing.assert_allclose(rho, np.eye(3), atol=0.03)


@pytest.mark.parametrize("corr, message", [
    ([[1, 0.5], [0.5, 1]],
     "uncertainty.correlation: a correlation matrix is 3 rows of 3 numbers, one per sampled input "
     "in the table's order (vehicles.0.speed, vehicles.1.weight, "
     "contacts.0.unloading.restitution), or pairs [[path_a, path_b, rho], ...]; got shape 2x2"),
    ([[1, 0.5, 0], [0.4, 1, 0], [0, 0, 1]],
     "uncertainty.correlation: the matrix must be symmetric; [0][1] = 0.5 but [1][0] = 0.4"),
    ([[1, 0, 0], [0, 2, 0], [0, 0, 1]],
     "uncertainty.correlation: the diagonal must be 1 (an input's correlation with itself); "
     "entry [1][1] (vehicles.1.weight) is 2"),
    ([[1, 0.9, 0.9], [0.9, 1, -0.9], [0.9, -0.9, 1]],
     "uncertainty.correlation: the rank correlation matrix must be positive definite (its "
     "smallest eigenvalue is -0.8): no inputs can have these correlations together"),
    ([["vehicles.0.speed", "vehicles.0.weight", 0.5]],
     "uncertainty.correlation[0]: 'vehicles.0.weight' is not a sampled input; the sampled inputs "
     "are vehicles.0.speed, vehicles.1.weight, contacts.0.unloading.restitution"),
    ([["vehicles.0.speed", "vehicles.1.weight", 0.5], ["vehicles.1.weight", "vehicles.0.speed", 0.2]],
     "uncertainty.correlation[1]: each pair names two different inputs once; got "
     "['vehicles.1.weight', 'vehicles.0.speed', 0.2]"),
])
def test_bad_correlation_is_refused_naming_the_field(corr, message):
    with pytest.raises(lsc.SceneError) as e:
        sample(paper_scene(), {**THREE, "correlation": corr}, 10, seed=0)
    assert str(e.value) == message


def test_a_choice_cannot_be_rank_correlated():
    d = {"vehicles.0.speed": {"uniform": [4, 8]}, "vehicles.1.weight": [3000, 3500, 4000],
         "correlation": [[1, 0.5], [0.5, 1]]}
    with pytest.raises(lsc.SceneError) as e:
        sample(paper_scene(), d, 10, seed=0)
    assert e.value.path == "uncertainty.correlation"
    assert "vehicles.1.weight is a choice" in str(e.value)
    d["correlation"] = [[1, 0], [0, 1]]
    assert set(sample(paper_scene(), d, 10, seed=0)["vehicles.1.weight"]) <= {3000, 3500, 4000}


def test_lsc_mc_sampling_option(tmp_path, capsys):
    import lsc.cli
    f = tmp_path / "s.toml"
    f.write_text('units = "US"\ng = "32.2 ft/s^2"\n'
                 '[[vehicles]]\nweight = 3500\nspeed = 5\n[[vehicles]]\nweight = 3500\nspeed = 0\n'
                 '[[contacts]]\nloading = { stiffness = 24000 }\nunloading = { restitution = 0.4 }\n'
                 '[uncertainty]\n"vehicles.0.speed" = { uniform = [4, 8] }\n'
                 '"vehicles.1.weight" = { uniform = [3000, 4000] }\n'
                 'correlation = [["vehicles.0.speed", "vehicles.1.weight", 0.5]]\n')
    assert lsc.cli.main(["mc", str(f), "--n", "64", "--sampling", "lhs", "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "(seed 0, Latin hypercube)" in text
    assert "rank correlation: vehicles.0.speed ~ vehicles.1.weight 0.5" in text
    assert lsc.cli.main(["mc", str(f), "--n", "64", "--sampling", "grid"]) == 2
