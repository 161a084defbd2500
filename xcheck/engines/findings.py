"""What ``xcheck releases`` found, recorded for the checks that quote it (issue 29): an older MuJoCo's (or MJX's) failed
RK4 order check names the finding and the first good release (:mod:`xcheck.study.checks`). No imports: the study
reads it without loading the release machinery."""

from __future__ import annotations

#: The newest patch of every minor release from 3.2 to 4.0 (PyPI, 2026-12-02)
RELEASES = ("3.2.7", "3.3.7", "3.4.0", "3.5.0", "3.6.0", "3.7.0", "3.8.1", "3.9.0", "3.10.0", "3.11.0", "3.12.0",
            "3.13.0", "3.14.0", "3.15.0", "3.16.0", "3.17.0", "4.0.0")
#: The first release whose RK4 is fourth order on a free body (``xcheck releases``, docs/mujoco-releases.md):
#: before it, order 2 on every bundled scenario, free and ball joints alike
RK4_FOURTH_ORDER_FROM = "4.0.0"


def release_key(version: str) -> tuple:
    return tuple(int(x) for x in version.split("."))


def release_note(version: str | None, engine: str = "MuJoCo") -> str | None:
    """For a failed RK4 order check on MuJoCo ``version`` (or MJX's, which follows MuJoCo's numbering): the finding
    and the first good release; None from it on."""
    if not version or version == "not installed" or release_key(version) >= release_key(RK4_FOURTH_ORDER_FROM):
        return None
    if engine == "MJX":
        return (f"a known finding: MJX {version}'s RK4 is second order on rotating bodies, as MuJoCo's before "
                f"{RK4_FOURTH_ORDER_FROM} (docs/mjx.md)")
    return (f"a known finding: MuJoCo {version}'s RK4 is second order on rotating bodies (free and ball joints, "
            f"every bundled scenario); fourth order from MuJoCo {RK4_FOURTH_ORDER_FROM} on (docs/mujoco-releases.md)")
