"""The readable references of the filter (gnssatt.attitude.reference_*, gnssatt.estimation.ekf_reference) are the
specification of the compiled kernels: they must stay plain numpy, independent of numba and of the kernels."""
import subprocess
import sys

REFERENCE_MODULES = ["gnssatt.estimation.ekf_reference", "gnssatt.attitude.reference_noise",
                     "gnssatt.attitude.reference_qc", "gnssatt.attitude.reference_propagate",
                     "gnssatt.attitude.reference_update", "gnssatt.attitude.reference_records",
                     "gnssatt.attitude.reference_states"]


def test_references_import_neither_numba_nor_the_kernels():
    code = ("import sys\n" + "".join(f"import {m}\n" for m in REFERENCE_MODULES)
            + "bad = sorted(m for m in sys.modules if m == 'numba' or m.startswith('numba.')"
              " or m.endswith('_kernels'))\nprint(','.join(bad))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", out.stdout
