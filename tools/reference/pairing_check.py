#!/usr/bin/env python3
"""pairing_check.py DIR [K_N_PER_A ZETA_RAD POLE_PITCH_M]

Which setpoint made the measured force? Fits, per coil set, a position-
resolved model of DIR/experiments.csv (clm commission's output; a
magnitude/phase drive): K_a(y) i_a + K_b(y) i_b + F_cog(y) + C tanh(v/2 mm/s)
+ offset, with K_a, K_b and F_cog as 1 mm hat functions, the currents
reconstructed through the drive's commutation (k̂_d, ζ̂_d; default: the
embedded default motor's 67 N/A, -0.52 rad, 30 mm), pairing each row's force
with the setpoint of its own row and with that of the row before. Prints
the residual RMS of both pairings and the correlation of the own-row
residual with d(magnitude)/dt. Run it on noise-free data (force noise 0 in
the motor file) to see the model error alone (docs/commutation.md, "Before
and after"). Uses numpy only.
"""
import sys

import numpy as np


def main():
    if len(sys.argv) not in (2, 5):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    k, zeta, pitch = (67.0, -0.52, 0.03) if len(sys.argv) == 2 else map(float, sys.argv[2:5])
    d = np.genfromtxt(sys.argv[1] + "/experiments.csv", delimiter=",", names=True)
    for coil_set in np.unique(d["coil_set"]).astype(int):
        rows = d[d["coil_set"] == coil_set]
        t, y, mag, delta, force = rows["t_s"], rows["y_m"], rows["magnitude_N"], rows["delta_rad"], rows["Fy_N"]
        step = np.diff(t)
        # Rows whose predecessor is the previous cycle of the same run and offset.
        paired = np.r_[False, (step > 0) & (step <= 1.5 * np.median(step[step > 0])) & (np.diff(delta) == 0)]
        velocity = np.zeros_like(y)
        velocity[paired] = (y[paired] - y[np.flatnonzero(paired) - 1]) / step[paired[1:]]
        dmag = np.zeros_like(y)
        dmag[paired] = (mag[paired] - mag[np.flatnonzero(paired) - 1]) / step[paired[1:]]
        keep = np.flatnonzero(paired)
        low, width = y.min(), 1e-3
        count = int(np.ceil((y.max() - low) / width)) + 2

        def residual(setpoint_rows):
            angle = 2 * np.pi * y[keep] / pitch + zeta + delta[setpoint_rows]
            ia = mag[setpoint_rows] / k * np.sin(angle)
            ib = mag[setpoint_rows] / k * np.sin(angle + 2 * np.pi / 3)
            u = (y[keep] - low) / width
            j = np.floor(u).astype(int)
            w = u - j

            def hat(values):
                columns = np.zeros((len(keep), count))
                columns[np.arange(len(keep)), j] += (1 - w) * values
                columns[np.arange(len(keep)), j + 1] += w * values
                return columns

            x = np.hstack([hat(ia), hat(ib), hat(np.ones(len(keep))), np.tanh(velocity[keep] / 0.002)[:, None],
                           np.ones((len(keep), 1))])
            coefficients, *_ = np.linalg.lstsq(x, force[keep], rcond=None)
            return force[keep] - x @ coefficients

        own = residual(keep)
        previous = residual(keep - 1)
        print(f"coil set {coil_set}: {len(keep)} rows; residual RMS {np.sqrt(np.mean(own ** 2)):.3g} N with the own "
              f"row's setpoint, {np.sqrt(np.mean(previous ** 2)):.3g} N with the previous row's; correlation of "
              f"the first with d(magnitude)/dt {np.corrcoef(own, dmag[keep])[0, 1]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
