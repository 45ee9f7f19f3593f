"""Accuracy planning before flight: satellites in view, DOPs, ADOP and CRLB bounds, expected Euler sigmas.

Modules: `bounds` (seed 001 eq. 4-6: CRLB of an angle of arrival, ADOP, sigma_R), `baseline_dop` (seed 000
eq. 3-4 and Table 4: baseline DOPs -> horizontal / vertical baseline sigmas -> yaw / pitch / roll sigmas, and
the full snapshot covariance of all baselines), `trajectory` (the platform's orbit from a TLE, Keplerian
elements or SP3, or a ground position), `satellites` (GNSS positions from a navigation file), `series` (the time
series of a plan), `plots`."""
