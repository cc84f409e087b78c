"""Shared helpers of the plot scripts: they read only results/ and write into paper/."""
import os
import sys
from fractions import Fraction

import h5py  # noqa: F401  (Debian's python3-h5py; run with /usr/bin/python3)
import matplotlib

matplotlib.use("Agg")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(ROOT, "results")
PAPER = os.path.join(ROOT, "paper")
FIGURES = os.path.join(PAPER, "figures")


def result_path(name):
    path = os.path.join(RESULTS, name)
    if not os.path.exists(path):
        sys.exit(f"plots: {path} is missing: run scripts/reproduce first")
    return path


def save(fig, name):
    os.makedirs(FIGURES, exist_ok=True)
    for ext in ("png", "pdf"):
        fig.savefig(os.path.join(FIGURES, f"{name}.{ext}"), dpi=150, bbox_inches="tight")
    print(f"plots: wrote paper/figures/{name}.png and .pdf")


def nice(c, tol=1e-6):
    """A fit coefficient as a small fraction when it is one, else a decimal."""
    f = Fraction(c).limit_denominator(12)
    if abs(float(f) - c) <= tol * max(1.0, abs(c)):
        return str(f) if f.denominator != 1 else str(f.numerator)
    return f"{c:.4g}"


def poly_formula(coeffs, var="n"):
    """a·n³ + b·n² + c·n + d as text, from [a, b, c, d]."""
    terms = []
    for c, p in zip(coeffs, (3, 2, 1, 0)):
        if abs(c) < 1e-6:
            continue
        s = nice(abs(c))
        mono = {3: f"{var}³", 2: f"{var}²", 1: var, 0: ""}[p]
        body = (mono if s == "1" and p else (f"{s}{mono}" if p else s))
        terms.append(("− " if c < 0 else "+ ") + body)
    if not terms:
        return "0"
    out = " ".join(terms)
    return out[2:] if out.startswith("+ ") else "−" + out[2:]


PROVENANCE_KEYS = ("git_sha", "cpu_model", "cpu_signature", "cpu_extensions", "build_isa",
                   "abi_isa", "compiler", "blas_library", "date_utc")


def cpu_name(f):
    """The CPU a result file was measured on, as precisely as its provenance tells it."""
    a = f.attrs

    def get(k):
        v = a.get(k)
        return v.decode() if isinstance(v, bytes) else v
    name = get("cpu_model") or "unknown CPU"
    if get("cpu_signature"):
        name += f" ({get('cpu_vendor') or ''} {get('cpu_signature')}; {get('cpu_extensions')})"
    return name


def short_sha(sha):
    """A git_sha attribute shortened to 7 hex digits, keeping its "-dirty" mark (a binary built
    from sources that differ from the commit)."""
    sha = sha.decode() if isinstance(sha, bytes) else str(sha)
    return sha.split("-")[0][:7] + ("-dirty" if sha.endswith("-dirty") else "")


def provenance_line(f):
    """The result file's provenance in one line: commit, CPU, compiler, BLAS, date (the writer's
    attribute names, experiments/lib/provenance.hpp)."""
    a = f.attrs
    return ", ".join(f"{k}={a[k].decode() if isinstance(a[k], bytes) else a[k]}"
                     for k in PROVENANCE_KEYS if k in a)
