"""A correct solver written in Python, for trying the harness (minv.check, minv.compare) and as
the Python baseline of python/bench_overhead.py: M by CRBA (minv.mass_matrix), then scipy's
dense Cholesky. Needs scipy (Debian's python3-scipy)."""
import numpy as np
import scipy.linalg

from . import mass_matrix


class ScipyCholesky:
    """M⁻¹ and M⁻¹R by CRBA and scipy.linalg.cho_factor / cho_solve."""

    def prepare(self, model):
        self.model = model
        self.eye = np.eye(model.nv)

    def configure(self, q):
        self.factor = scipy.linalg.cho_factor(mass_matrix(self.model, q))

    def inverse(self):
        return scipy.linalg.cho_solve(self.factor, self.eye)

    def solve(self, R):
        return scipy.linalg.cho_solve(self.factor, R)
