"""The quick report's numbers, kept as a golden copy (``tests/data/quick-report.json``) so that refactors show
they change nothing (issue 9: "every number in today's report must not move").

:func:`canonical` keeps what a report *says* (statuses, errors, drifts, orders, checks, verdicts) and drops
what varies from run to run, clone to clone or machine to machine (times, speeds, versions, the folders of
models and tables, numbers inside prose); checks are keyed by name. :func:`compare` checks a report against
the copy (new keys may be added, none may go): text and statuses exactly; errors and drifts to rtol 1e-9 and
atol 1e-15 (round-off where arithmetic is reordered); observed orders to 1e-3 (an order is a log of error
ratios, so 1e-15 on an error of 1e-12 moves it by about 1e-3).

Regenerate after an intended change of numbers: ``python tests/golden.py reports/latest/results.json`` on a
fresh ``xcheck report --quick``, and say in the commit why the numbers moved.
"""

import json
import math
import re
import sys
from pathlib import Path

GOLDEN = Path(__file__).parent / "data" / "quick-report.json"
_VOLATILE = {"created", "versions", "machine", "wall_time", "throughput", "steps_per_second"}
_ORDERS = {"observed_order", "local_orders"}
_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


def canonical(doc):
    """A copy of ``doc`` without the volatile keys; model paths by file name; numbers in notes as ``#``."""
    if isinstance(doc, dict):
        out = {}
        for k, v in doc.items():
            if k in _VOLATILE:
                continue
            if k in ("model", "table") and isinstance(v, str):  # paths differ between clones
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


def compare(got, want, path="", key=""):
    """A list of differences between two canonical documents (empty when they agree)."""
    if isinstance(want, dict):  # every key of the copy must be there; new keys may be added (issue 9)
        if not isinstance(got, dict) or not set(want) <= set(got):
            return [f"{path}: keys {sorted(got) if isinstance(got, dict) else got!r} lack {sorted(want)}"]
        return [d for k in want for d in compare(got[k], want[k], f"{path}/{k}", k)]
    if isinstance(want, list):
        if not isinstance(got, list) or len(got) != len(want):
            return [f"{path}: {got!r} != {want!r}"]
        return [d for i, (g, w) in enumerate(zip(got, want)) for d in compare(g, w, f"{path}[{i}]", key)]
    if isinstance(want, float) and isinstance(got, (int, float)) and not isinstance(got, bool):
        tol = 1e-3 if key in _ORDERS else 1e-9 * abs(want) + 1e-15
        return [] if math.isclose(got, want, rel_tol=0, abs_tol=tol) else [f"{path}: {got!r} != {want!r}"]
    return [] if got == want and type(got) is type(want) else [f"{path}: {got!r} != {want!r}"]


if __name__ == "__main__":
    doc = canonical(json.loads(Path(sys.argv[1]).read_text()))
    GOLDEN.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
