"""Attitude from one GNSS antenna (seed 001 sec. IV-VI).

Modules: `wahba` (Wahba's problem by SVD, the q-method check, Markley's covariance, degeneracy flags),
`gravity` (J2 gravity and the ECEF centrifugal / Coriolis terms), `differentiate` (the differentiating
filter of GNSS velocity), `specific_force` (GNSS velocity -> specific force in ECEF), `accelerometer`
(the accelerometer model of sec. VI: lever arm, angular-rate terms, bias), `geomagnetic` (IGRF-14 via
ppigrf; the sensor CSVs are read by gnssatt.gnss.io.sensor_csv), `acc_mag`
(the acceleration-magnetometer method), `boresight` (C/N0 boresight: weighted mean and gain-pattern fit).
Vectors (..., 3), xyz last, frames in the names (gnssatt.gnss conventions)."""
