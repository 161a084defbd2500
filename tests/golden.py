"""The quick report's numbers, kept as a golden copy (``tests/data/quick-report.json``) so that refactors show
they change nothing (issue 9: "every number in today's report must not move").

:func:`canonical` keeps what a report *says* (statuses, errors, drifts, orders, checks, verdicts) and drops
what varies from run to run, clone to clone or machine to machine (times, speeds, versions, the folders of
models and tables, numbers inside prose); checks are keyed by name. :func:`compare` checks a report against
the copy; new keys may be added, none may go. Statuses, verdicts and check outcomes must match exactly on
every machine. Numbers:

* **Machine-independent** (our compiled kernels, the exact references, MuJoCo): errors and drifts to rtol 1e-9
  and atol 1e-15 (round-off where arithmetic is reordered), observed orders and a trajectory file's error growth
  ``t^p`` to 1e-3 (each is a log of error ratios, so 1e-15 on an error of 1e-12 moves it by about 1e-3: a NASA
  file's growth moved by 2e-7 between two AMD EPYC machines), notes exactly.
* **Through BLAS**: scipy's solvers (the ``dop853`` reference, the ``scipy-rk45`` method) form their stage
  sums with small matrix products, and OpenBLAS picks its kernels, hence the order of the additions, by CPU:
  measured, the same code, versions and inputs give a DOP853 reference 1e-13 rad from the truth on an AMD
  EPYC (Zen kernels) and 1.6e-12 rad on an Intel Skylake-X (``OPENBLAS_CORETYPE=SkylakeX`` reproduces the
  latter on the former). There errors agree to within the study's round-off floor (``order_floor``: 10x the
  smallest error, which bounds the reference's own error), orders to 0.05 where both are measured; where the
  floor itself moved by more than 2x, an order may be measured on one machine and not on the other (the
  steps then lie within the floor), and the notes that name numbers or the closest method are not compared.
* **Prose with numbers** (a determination check's ``text``, which has no value of its own): the words exactly,
  each number to 1e-3 relative or 1e-14 absolute (the noise-free recovery of an attitude is round-off, 1e-15 rad,
  which the SVD and eigen-solvers of LAPACK reach by CPU-dependent paths).

Either way, the largest step within a tolerance (and the cost there) is interpolated between two runs' errors:
an error that moved by the absolute tolerance above (1e-15, or the floor) moves it by at most that over the
tolerance it is compared to, relative (divided by the order, >= 1): on two AMD EPYC machines, 4e-8 relative at
1e-9 rad with an exact reference (numpy's SIMD reductions), 2e-7 with DOP853.

For a refactor, compare two reports of the same machine exactly: ``python tests/golden.py --exact BEFORE.json
AFTER.json`` (every float, bit for bit).

Regenerate after an intended change of numbers: ``python tests/golden.py reports/latest/results.json`` on a
fresh ``xcheck report --quick``, and say in the commit why the numbers moved.
"""

import json
import math
import re
import sys
from pathlib import Path

GOLDEN = Path(__file__).parent / "data" / "quick-report.json"
_VOLATILE = {"created", "versions", "machine", "wall_time", "throughput", "steps_per_second", "solutions_per_second",
             "repeats"}
_ORDERS = {"observed_order", "local_orders", "growth"}  # a trajectory file's growth: a log-log fit too
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")
#: ``.../largest_step_within/1e-09`` and ``.../cost_within/1e-09/dt``: a step interpolated at that tolerance
_STEP_AT = re.compile(r"/(?:largest_step_within|cost_within)/([0-9.]+e[-+]?[0-9]+)(?:/dt)?$")


def _prose_agrees(got: str, want: str) -> bool:
    """The same words, and every number to 1e-3 relative or 1e-14 absolute (see the module docstring)."""
    if _NUMBER.sub("#", got) != _NUMBER.sub("#", want):
        return False
    pairs = zip((float(m.group()) for m in _NUMBER.finditer(got)), (float(m.group()) for m in _NUMBER.finditer(want)))
    return all(math.isclose(g, w, rel_tol=1e-3, abs_tol=1e-14) for g, w in pairs)


def canonical(doc):
    """A copy of ``doc`` without the volatile keys; model paths by file name; numbers in notes as ``#``."""
    if isinstance(doc, dict):
        out = {}
        for k, v in doc.items():
            if k in _VOLATILE:
                continue
            if k in ("model", "table", "file") and isinstance(v, str):  # paths differ between clones
                v = Path(v).name
            elif k in ("note", "order_note", "message") and isinstance(v, str):
                v = _NUMBER.sub("#", v)
            elif k == "checks" and isinstance(v, list):  # by name: a method added later adds checks, moves none
                v = {c["name"]: c for c in v}
            out[k] = canonical(v)
        return out
    if isinstance(doc, list):
        return [canonical(v) for v in doc]
    return doc


#: Reference kinds and methods whose numbers pass through BLAS (see the module docstring).
BLAS_REFERENCES = {"dop853"}
BLAS_METHODS = {"scipy-rk45"}
_ERRORS_PER_RUN = {"attitude_error", "max_attitude_error", "omega_error", "max_omega_error"}


class _Context:
    """How closely numbers must agree where the walk is (see the module docstring)."""

    def __init__(self, floor=None):
        self.floor = floor  # None: machine-independent; else the round-off floor [rad] of a BLAS-dependent part
        self.floor_moved = False

    def blas(self, floor, moved):
        ctx = _Context(floor)
        ctx.floor_moved = moved
        return ctx


def compare(got, want, path="", key="", ctx=None):
    """A list of differences between two canonical documents (empty when they agree)."""
    ctx = ctx or _Context()
    if isinstance(want, dict):  # every key of the copy must be there; new keys may be added (issue 9)
        if not isinstance(got, dict) or not set(want) <= set(got):
            return [f"{path}: keys {sorted(got) if isinstance(got, dict) else got!r} lack {sorted(want)}"]
        if "schema" in want and "methods" in want:  # one scenario: is its reference computed through BLAS?
            return _compare_scenario(got, want, path, ctx)
        return [d for k in want for d in compare(got[k], want[k], f"{path}/{k}", k, ctx)]
    if isinstance(want, list):
        if ctx.floor is not None and key == "local_orders":
            return []  # summarised by observed_order, compared below
        if not isinstance(got, list) or len(got) != len(want):
            return [f"{path}: {got!r} != {want!r}"]
        return [d for i, (g, w) in enumerate(zip(got, want)) for d in compare(g, w, f"{path}[{i}]", key, ctx)]
    if ctx.floor is not None and key in ("note", "order_note", "order_floor"):
        return []
    if key == "text" and isinstance(want, str) and isinstance(got, str):
        return [] if _prose_agrees(got, want) else [f"{path}: {got!r} != {want!r}"]
    step_at = _STEP_AT.search(path)
    if step_at and isinstance(want, float) and isinstance(got, float):
        rtol = 1e-9 + (1e-15 if ctx.floor is None else ctx.floor) / float(step_at.group(1))
        return [] if math.isclose(got, want, rel_tol=rtol) else [f"{path}: {got!r} != {want!r} (rtol {rtol:.1e})"]
    is_order = key in _ORDERS or (key == "value" and "/checks/order:" in path)
    if ctx.floor is not None and is_order and (got is None) != (want is None) and ctx.floor_moved:
        return []  # the steps lie within the floor on one machine
    if isinstance(want, float) and isinstance(got, (int, float)) and not isinstance(got, bool):
        if is_order:
            tol = 1e-3 if ctx.floor is None else 0.05
        else:
            tol = 1e-9 * abs(want) + (1e-15 if ctx.floor is None else ctx.floor)
        return [] if math.isclose(got, want, rel_tol=0, abs_tol=tol) else [f"{path}: {got!r} != {want!r}"]
    return [] if got == want and type(got) is type(want) else [f"{path}: {got!r} != {want!r}"]


def _compare_scenario(got, want, path, ctx):
    floor = max(got.get("order_floor") or 0.0, want.get("order_floor") or 0.0)
    lo = min(got.get("order_floor") or floor, want.get("order_floor") or floor)
    blas_ctx = ctx.blas(floor, floor > 2 * lo)
    whole = blas_ctx if want.get("reference") in BLAS_REFERENCES else ctx
    out = []
    for k in want:
        if k == "methods" and isinstance(want[k], dict) and isinstance(got[k], dict):
            for m in want[k]:
                if m not in got[k]:
                    out.append(f"{path}/methods: {m} missing")
                    continue
                c = blas_ctx if m in BLAS_METHODS else whole
                out += compare(got[k][m], want[k][m], f"{path}/methods/{m}", m, c)
        elif k == "checks" and isinstance(want[k], dict) and isinstance(got[k], dict):
            for name in want[k]:
                if name not in got[k]:
                    out.append(f"{path}/checks: {name} missing")
                    continue
                c = blas_ctx if name.split(":")[-1] in BLAS_METHODS else whole
                out += compare(got[k][name], want[k][name], f"{path}/checks/{name}", name, c)
        elif k == "order_floor" and set(got.get("methods", {})) - set(want.get("methods", {})):
            # methods added since the copy (Basilisk's, when installed) can only lower the floor: 10x the
            # smallest error any method reached
            if not (isinstance(got[k], float) and got[k] <= want[k] * (1 + 1e-9)):
                out.append(f"{path}/{k}: {got[k]!r} above {want[k]!r} with methods added")
        else:
            out += compare(got[k], want[k], f"{path}/{k}", k, whole)
    return out


def compare_exact(got, want, path=""):
    """Every difference between two raw ``results.json`` documents of the same machine, floats bit for bit
    (times, speeds and versions excepted)."""
    if isinstance(want, dict):
        return [d for k in want if k not in _VOLATILE
                for d in ([f"{path}/{k}: missing"] if k not in got else compare_exact(got[k], want[k], f"{path}/{k}"))]
    if isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            return [f"{path}: length {len(got) if isinstance(got, list) else got!r} != {len(want)}"]
        return [d for i, (g, w) in enumerate(zip(got, want)) for d in compare_exact(g, w, f"{path}[{i}]")]
    same = got == want or (isinstance(want, float) and isinstance(got, float) and math.isnan(got) and math.isnan(want))
    return [] if same else [f"{path}: {got!r} != {want!r}"]


if __name__ == "__main__":
    if sys.argv[1] == "--exact":
        before, after = (json.loads(Path(p).read_text()) for p in sys.argv[2:4])
        differences = compare_exact(after, before)
        print("\n".join(differences[:50]) or "identical (every float bit for bit; times, speeds, versions aside)")
        sys.exit(1 if differences else 0)
    doc = canonical(json.loads(Path(sys.argv[1]).read_text()))
    GOLDEN.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
