"""The analyses load no heavy optional dependency until they need it: finite-difference
sensitivities, bounds and Monte Carlo run without JAX (DESIGN.md section 3)."""

import subprocess
import sys


def test_analyses_without_jax_or_matplotlib():
    code = (
        "import sys, lsc, lsc.analysis as a; "
        "scene = {'vehicles': [{'mass': 1000, 'speed': 3}, {'mass': 1200, 'speed': 0}], "
        "'contacts': [{'loading': {'stiffness': 1e5}, 'unloading': {'restitution': 0.5}}]}; "
        "s = a.sensitivity(scene, method='finite-difference'); "
        "assert abs(s.derivative('delta_v', 'contacts.0.unloading.restitution') - 3000 / 2200) < 1e-9; "
        "a.monte_carlo(scene, {'vehicles.0.speed': {'uniform': [2, 4]}}, 100, seed=0, progress=False); "
        "print(' '.join(m for m in ('jax', 'diffrax', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
