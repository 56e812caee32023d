"""Generate the packaged SYNTHETIC crash-test data set (lsc/data/synthetic_test.csv and .zip).

It is NOT a measured crash test: it is the simulation of the packaged default scene (the paper's
parametric study 1 at e = 0.4: two 3500 lbf cars, the bullet at 10 ft/s, 24,000 lbf/ft), sampled
at 10 kHz from 20 ms before first contact (the pre-trigger) to 200 ms after it, with Gaussian
sensor noise added (accelerations 0.05 g, force 20 lbf, deformation 0.005 in r.m.s., seed 14)
and every channel filtered to SAE J211 CFC 60. Written twice, with the same numbers:

- ``synthetic_test.csv``: ``time [s], accel_bullet [g], accel_target [g], force [lbf],
  deformation [in]``;
- ``synthetic_test.zip``: an ISO-MME 1.6 data set (``SYNTH14.mme``, ``Channel/SYNTH14.chn``,
  ``Channel/SYNTH14.001`` ...), the channel names in ``Name of the channel``.

    python scripts/make_synthetic_test.py            # rewrites the files in lsc/data/
    python scripts/make_synthetic_test.py --out DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import lsc
import lsc.data
from lsc.analysis.channels import Channel, Channels, write_csv, write_isomme
from lsc.analysis.filters import cfc_filter

RATE = 10_000.0                  # Hz
PRE, POST = 0.02, 0.2            # s before and after first contact
DECIMALS = {"accel_bullet": 5, "accel_target": 5, "force": 2, "deformation": 5}   # g, lbf, in
NOISE = {"accel_bullet": 0.05, "accel_target": 0.05, "force": 20.0, "deformation": 0.005}
CODES = {"accel_bullet": "10VEHC0000ACXD", "accel_target": "20VEHC0000ACXD",
         "force": "10BUMP0000FOXD", "deformation": "10BUMP0000DSXD"}
COMMENT = ("SYNTHETIC DATA, not a crash test: lsc simulation of the packaged default scene plus "
           "Gaussian noise (seed 14), filtered to J211 CFC 60; made by scripts/make_synthetic_test.py")


def synthetic_channels(seed: int = 14) -> Channels:
    """The synthetic channels: the default scene simulated, sampled, noised and CFC 60 filtered."""
    result = lsc.solve(lsc.data.load("default"))
    g = result.scene.g
    t = np.round(np.arange(-PRE * RATE, POST * RATE + 1) / RATE, 12)
    inside = lambda y: np.interp(t, result.t, y, left=0.0, right=0.0)  # noqa: E731  no contact outside
    clean = {"accel_bullet": (inside(result.a[:, 0]) / g, "g"),
             "accel_target": (inside(result.a[:, 1]) / g, "g"),
             "force": (inside(result.force[:, 0]), "lbf"),
             "deformation": (np.interp(t, result.t, result.deformation[:, 0] * 12.0, left=0.0), "in")}
    rng = np.random.default_rng(seed)
    chans = {}
    for name, (values, unit) in clean.items():
        noisy = values + rng.normal(0.0, NOISE[name], t.size)
        kind = {"g": "acceleration", "lbf": "force", "in": "displacement"}[unit]
        chans[name] = Channel(name, np.round(cfc_filter(noisy, 60, RATE), DECIMALS[name]), unit, kind, "synthetic")
    return Channels(t, chans, "synthetic", cfc=60)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(lsc.__file__).parent / "data")
    args = parser.parse_args(argv)
    channels = synthetic_channels()
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path = write_csv(channels, args.out / "synthetic_test.csv")
    text = csv_path.read_text()
    csv_path.write_text(f"# {COMMENT}\n" + text)
    write_isomme(channels, args.out / "synthetic_test.zip", test="SYNTH14", comments=(COMMENT,), codes=CODES)
    print(f"wrote {csv_path} and {args.out / 'synthetic_test.zip'}")


if __name__ == "__main__":
    main()
