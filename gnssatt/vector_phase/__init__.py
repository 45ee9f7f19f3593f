"""Single-antenna carrier-phase attitude from the antenna's vector effective length (seed 003, Bahder).

One module per idea:
- `antenna`: receive-antenna vector effective length h(theta, phi) (short dipole, ideal RHCP patch, a patch
  with a non-symmetric phase pattern, a table on a grid) and its Cartesian form (eq. 12, 22-24).
- `pattern_file`: antenna_pattern.json (docs/formats/antenna_vector_length.md) read and written.
- `transmitter`: the satellite's field polarisation u - j v (eq. 15) from the satellite attitude.
- `satellite_attitude`: nominal yaw steering (the project's ERFA Sun and IGS axes) and the
  orbit-frame axes; the transmitter attitude is otherwise any callable/array of rotations per epoch.
- `phase_model`: delta_s (eq. 32) and the carrier phase of eq. 34-36 and the phase change of eq. 44.
- `rotation`: the body rotation increments and the paper's Euler matrix D (eq. 26).
- `observability`: rank and condition of the information matrix, the unobservable rotation.
- `batch`, `ekf`: estimators of position, clock and attitude from phase changes (eq. 44-45).
- `scenario`: a simulated single-antenna scenario with known truth (tests, bench).
- `products`, `api`: the result record, products() / write_products().

Nothing is imported here, so the simulator can import the phase model without a cycle.
"""
