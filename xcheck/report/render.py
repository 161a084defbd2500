"""The report folder: ``results.json``, ``report.md``, a self-contained ``index.html`` (plots embedded),
the figures as PNG and the finest runs' trajectories as CSV. Written into a hidden temporary folder and
renamed into place only when complete; ``latest`` then points at it."""

from __future__ import annotations

import base64
import errno
import html
import os
import shutil
import socket
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from ..versions import machine, versions
from .io import write_json_atomic, write_text_atomic, write_trajectory_csv

__all__ = ["write_report", "REPORT_SCHEMA", "verdict_of"]

REPORT_SCHEMA = "xcheck.report/1"


def verdict_of(data: dict, method: str) -> str:
    """``pass`` | ``fail`` | ``expected`` (an expected failure that happened) for one method of a study."""
    if any(c["name"] == "reference" and not c["passed"] for c in data["checks"]):
        return "fail"  # nothing could be measured
    related = [c for c in data["checks"] if c["name"].split(":", 1)[-1] == method]
    if not related:
        return "info"
    if any(c["name"].startswith("expected-failure:") for c in related):
        return "expected" if all(c["passed"] for c in related) else "fail"
    return "pass" if all(c["passed"] for c in related) else "fail"


def _fmt(x, spec=".2e"):
    return "—" if x is None else format(x, spec)


def _dt(dt):
    k = np.log2(1 / dt)
    return f"1/{int(round(1 / dt))}" if abs(k - round(k)) < 1e-9 and dt < 1 else f"{dt:g}"


# ------------------------------------------------------------------------------------------------
def write_report(studies, out_root, *, stamp: str | None = None, throughput=None, wall_time=None,
                 quick=False, pool=None) -> Path:
    """Write the report of ``studies`` (list of StudyResult) under ``out_root/<stamp>/`` atomically and
    point ``out_root/latest`` at it; figures are drawn in ``pool`` when given. Returns the report folder.

    The report is written into a hidden ``.incomplete-<stamp>-<host>-<pid>`` folder and renamed into place
    when complete: on any error or interrupt the workers are stopped first and the folder removed; a
    folder left by a killed run (its process gone) is removed by the next report into ``out_root``. Two
    reports finishing in the same second get distinct names (``<stamp>-2``)."""
    from ..pool import stop_pool
    from .plots import scenario_figures

    out_root = Path(out_root)
    out_root.mkdir(parents=True, exist_ok=True)
    remove_stale(out_root)
    stamp = stamp or datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%SZ")
    tmp = out_root / f"{_INCOMPLETE}{stamp}-{_owner()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    try:
        if pool is not None:
            futures = {st.data["scenario"]: pool.submit(scenario_figures, st.data, st.series, tmp / "plots",
                                                        quick=quick) for st in studies}
        for st in studies:
            _write_csvs(st, tmp / "trajectories" / st.data["scenario"])
        figures = {name: fut.result() for name, fut in futures.items()} if pool is not None else {
            st.data["scenario"]: scenario_figures(st.data, st.series, tmp / "plots", quick=quick) for st in studies}
        results = {"schema": REPORT_SCHEMA, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                   "quick": quick, "versions": versions(), "machine": machine(),
                   "wall_time": wall_time, "passed": all(st.passed for st in studies),
                   "scenarios": [st.data for st in studies], "throughput": throughput or []}
        write_json_atomic(tmp / "results.json", results)
        write_text_atomic(tmp / "report.md", _markdown(results, figures))
        write_text_atomic(tmp / "index.html", _html(results, figures, tmp / "plots"))
        final = _rename_into_place(tmp, out_root, stamp)
    except BaseException:
        if pool is not None:
            stop_pool(pool)  # a worker still drawing would recreate the folder after it is removed
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    _point_latest(out_root, final)
    return final


_INCOMPLETE = ".incomplete-"


def _owner() -> str:
    """``<host>-<pid>``: who is writing a hidden temporary folder or link."""
    host = "".join(c if c.isalnum() else "_" for c in socket.gethostname())[:40] or "host"
    return f"{host}-{os.getpid()}"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, but not ours to signal
        return True
    return True


def remove_stale(out_root: Path) -> list[Path]:
    """Remove what killed runs on this host left in ``out_root``: ``.incomplete-*`` folders and ``.latest-*``
    links whose writing process is gone. Returns what was removed."""
    host = _owner().rsplit("-", 1)[0]
    removed = []
    for p in out_root.glob(".*-*"):
        if not (p.name.startswith(_INCOMPLETE) or p.name.startswith(".latest-")):
            continue
        owner_host, _, pid = p.name.rpartition("-")
        if not (pid.isdigit() and owner_host.endswith("-" + host)) or _alive(int(pid)):
            continue
        if p.is_symlink() or p.is_file():
            p.unlink(missing_ok=True)
        else:
            shutil.rmtree(p, ignore_errors=True)
        removed.append(p)
    return removed


def _rename_into_place(tmp: Path, out_root: Path, stamp: str) -> Path:
    """Rename ``tmp`` to ``out_root/<stamp>`` or, if another report took that name first, ``<stamp>-2``, ..."""
    for n in range(1, 10_000):
        final = out_root / (stamp if n == 1 else f"{stamp}-{n}")
        if final.exists():
            continue
        try:
            os.rename(tmp, final)
            return final
        except OSError as exc:  # taken between the check and the rename (a concurrent report)
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY) and not final.exists():
                raise
    raise OSError(errno.EEXIST, f"no free report name for {stamp} in {out_root}")


def _point_latest(out_root: Path, final: Path):
    link = out_root / "latest"
    tmp_link = out_root / f".latest-{_owner()}"
    try:
        tmp_link.unlink(missing_ok=True)
        tmp_link.symlink_to(final.name, target_is_directory=True)
        os.replace(tmp_link, link)
    except OSError:  # no symlinks here: a text file naming the folder
        tmp_link.unlink(missing_ok=True)
        write_text_atomic(out_root / "latest.txt", final.name + "\n")


def _write_csvs(st, folder: Path):
    folder.mkdir(parents=True, exist_ok=True)
    for method, s in st.series.items():
        write_trajectory_csv(
            folder / f"{method}.csv",
            f"{st.data['scenario']} / {method}: the finest run (dt = {s['dt']:.6g} s), sampled every "
            f"{max(s['dt'], 1 / 256):.6g} s; q [w, x, y, z] body->world, body rates in body components; "
            "attitude error against the reference (empty where it is not defined)",
            s["t"], s["q"], s["omega"], s["attitude_error"], s.get("euler"))


# ------------------------------------------------------------------------------------------------
# Markdown
# ------------------------------------------------------------------------------------------------
def _front_rows(results):
    methods = []
    for sc in results["scenarios"]:
        for m in sc["methods"]:
            if m not in methods:
                methods.append(m)
    return methods


def _cell(sc, m):
    if m not in sc["methods"]:
        return "", "none"
    e = sc["methods"][m]
    v = verdict_of(sc, m)
    finest = [r for r in e["runs"] if r["status"] == "ok"]
    err = min(finest, key=lambda r: r["dt"])["attitude_error"] if finest else None
    order = e["observed_order"]
    text = f"p={order:.2f}" if order is not None else (e["status"] if e["status"] != "ok" else "p=—")
    text += f" · {_fmt(err, '.1e')}"
    return text, v


_MARK = {"pass": "✅", "fail": "❌", "expected": "⚠️ expected", "info": "ℹ️", "none": ""}


def _markdown(results, figures) -> str:
    out = ["# xcheck cross-check report", ""]
    verdict = "**PASSED**: every check passed." if results["passed"] else "**FAILED**: some checks failed."
    out += [f"{verdict} Created {results['created']}" + (f" in {results['wall_time']:.1f} s" if results["wall_time"]
                                                         else "") + (" (quick)" if results["quick"] else "") + ".", ""]
    out += ["Each cell: the observed order p and the attitude error [rad] at the finest step. ✅ every check passed, "
            "❌ a check failed, ⚠️ a failure the scenario expects (e.g. Euler angles at gimbal lock), ℹ️ reported "
            "without checks.", ""]
    methods = _front_rows(results)
    out.append("| scenario | " + " | ".join(methods) + " |")
    out.append("|---|" + "---|" * len(methods))
    for sc in results["scenarios"]:
        cells = []
        for m in methods:
            text, v = _cell(sc, m)
            cells.append(f"{_MARK[v]} {text}".strip())
        out.append(f"| {sc['scenario']} | " + " | ".join(cells) + " |")
    out.append("")
    for sc in results["scenarios"]:
        out += _markdown_scenario(sc, figures.get(sc["scenario"], []))
    out += _markdown_appendix(results)
    return "\n".join(out) + "\n"


def _markdown_scenario(sc, figs):
    out = [f"## {sc['scenario']} — {'passed' if sc['passed'] else 'FAILED'}", "", sc.get("description", ""), ""]
    ini = sc["initial"]
    out += [f"Model `{sc['model']}`, {sc['duration']:g} s, reference **{sc['reference']}**; "
            f"q0 = {(np.round(ini['quaternion'], 6) + 0.0).tolist()}, ω0 = {(np.round(ini['angular_velocity'], 6) + 0.0).tolist()} "
            f"rad/s; torque: {sc['torque'] or 'none'}. Orders are measured above {sc['order_floor']:.2g} rad.", ""]
    out += ["| check | result | value | limit | note |", "|---|---|---|---|---|"]
    for c in sc["checks"]:
        out.append(f"| {c['name']} | {'pass' if c['passed'] else '**FAIL**'} | {_fmt(c['value'], '.3g')} | "
                   f"{_fmt(c['limit'], '.3g')} | {c['note']} |")
    out.append("")
    steps = sc["steps"]
    out.append("| method | expected | observed | " + " | ".join(_dt(d) for d in steps) + " |")
    out.append("|---|---|---|" + "---|" * len(steps))
    for m, e in sc["methods"].items():
        errs = {r["dt"]: (r["attitude_error"] if r["status"] == "ok" else r["status"]) for r in e["runs"]}
        cells = [(_fmt(errs[d], ".1e") if not isinstance(errs.get(d), str) else errs[d]) if d in errs else ""
                 for d in steps]
        out.append(f"| {m} | {e['expected_order'] if e['expected_order'] is not None else 'adaptive'} | "
                   f"{_fmt(e['observed_order'], '.2f')} | " + " | ".join(cells) + " |")
    out.append("")
    for file, caption in figs:
        out += [f"![{caption}](plots/{file})", "", f"*{caption}*", ""]
    return out


def _markdown_appendix(results):
    out = ["## Appendix: versions, machine, throughput", ""]
    out.append("Versions: " + ", ".join(f"{k} {v}" for k, v in results["versions"].items()) + ".")
    m = results["machine"]
    out += [f"Machine: {m['platform']}, {m['processor']}, {m['cpus']} CPUs.", ""]
    if results["throughput"]:
        out += ["| engine | method | scenario | batch | steps/s |", "|---|---|---|---|---|"]
        for r in results["throughput"]:
            out.append(f"| {r['engine']} | {r['method']} | {r['scenario']} | {r['batch']} | "
                       f"{r['steps_per_second']:.3g} |")
        out.append("")
    return out


# ------------------------------------------------------------------------------------------------
# HTML (self-contained)
# ------------------------------------------------------------------------------------------------
_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;max-width:1200px;
color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ddd;padding-bottom:.2em}
table{border-collapse:collapse;margin:1em 0;font-size:.85em}
th,td{border:1px solid #ddd;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#f4f4f4}td.num{text-align:right;font-family:ui-monospace,Menlo,Consolas,monospace}
td.pass{background:#dff5e1}td.fail{background:#fbdada}td.expected{background:#fff0c8}td.info{background:#eef}
.verdict{font-size:1.2em;padding:.5em 1em;display:inline-block;border-radius:4px}
.verdict.pass{background:#dff5e1}.verdict.fail{background:#fbdada}
figure{margin:1em 0}figure img{max-width:100%}figcaption{font-size:.85em;color:#555}
.small{font-size:.85em;color:#555}
"""


def _e(x):
    return html.escape(str(x))


def _html(results, figures, plot_dir: Path) -> str:
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>",
             "<title>xcheck cross-check report</title>", f"<style>{_CSS}</style></head><body>",
             "<h1>xcheck cross-check report</h1>"]
    ok = results["passed"]
    parts.append(f"<p class='verdict {'pass' if ok else 'fail'}'>{'PASSED: every check passed' if ok else 'FAILED: some checks failed'}</p>")
    parts.append(f"<p class='small'>Created {_e(results['created'])}"
                 + (f" in {results['wall_time']:.1f} s" if results["wall_time"] else "")
                 + (" (quick: fewer steps; the final-error and invariant checks need the full range and are "
                    "not applied)" if results["quick"] else "") + ". "
                 + "Versions: " + ", ".join(f"{_e(k)} {_e(v)}" for k, v in results["versions"].items())
                 + f". Machine: {_e(results['machine']['platform'])}, {results['machine']['cpus']} CPUs.</p>")
    parts.append("<p>Each cell: observed order <i>p</i> and attitude error [rad] at the finest step. Green: every "
                 "check passed; red: a check failed; amber: a failure the scenario expects (Euler angles at gimbal "
                 "lock); blue: reported without checks.</p>")
    methods = _front_rows(results)
    parts.append("<table><tr><th>scenario</th>" + "".join(f"<th>{_e(m)}</th>" for m in methods) + "</tr>")
    for sc in results["scenarios"]:
        row = [f"<td><a href='#{_e(sc['scenario'])}'>{_e(sc['scenario'])}</a></td>"]
        for m in methods:
            text, v = _cell(sc, m)
            row.append(f"<td class='{v}'>{_e(text)}</td>")
        parts.append("<tr>" + "".join(row) + "</tr>")
    parts.append("</table>")
    for sc in results["scenarios"]:
        parts += _html_scenario(sc, figures.get(sc["scenario"], []), plot_dir)
    parts += _html_appendix(results)
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _html_scenario(sc, figs, plot_dir):
    out = [f"<h2 id='{_e(sc['scenario'])}'>{_e(sc['scenario'])} — "
           f"<span class='verdict {'pass' if sc['passed'] else 'fail'}'>{'passed' if sc['passed'] else 'FAILED'}</span></h2>",
           f"<p>{_e(sc.get('description', ''))}</p>"]
    ini = sc["initial"]
    out.append(f"<p class='small'>Model <code>{_e(sc['model'])}</code>, {sc['duration']:g} s, reference "
               f"<b>{_e(sc['reference'])}</b>; q0 = {_e((np.round(ini['quaternion'], 6) + 0.0).tolist())}, ω0 = "
               f"{_e((np.round(ini['angular_velocity'], 6) + 0.0).tolist())} rad/s; torque: {_e(sc['torque'] or 'none')}. "
               f"Orders are measured on errors above {sc['order_floor']:.2g} rad.</p>")
    out.append("<table><tr><th>check</th><th>result</th><th>value</th><th>limit</th><th>note</th></tr>")
    for c in sc["checks"]:
        cls = "pass" if c["passed"] else "fail"
        if c["name"].startswith("expected-failure:") and c["passed"]:
            cls = "expected"
        out.append(f"<tr><td>{_e(c['name'])}</td><td class='{cls}'>{'pass' if c['passed'] else 'FAIL'}</td>"
                   f"<td class='num'>{_fmt(c['value'], '.3g')}</td><td class='num'>{_fmt(c['limit'], '.3g')}</td>"
                   f"<td>{_e(c['note'])}</td></tr>")
    out.append("</table>")
    steps = sc["steps"]
    out.append("<table><tr><th>method</th><th>expected</th><th>observed</th>"
               + "".join(f"<th>{_dt(d)}</th>" for d in steps) + "<th>steps/s</th></tr>")
    for m, e in sc["methods"].items():
        by_dt = {r["dt"]: r for r in e["runs"]}
        cells = []
        for d in steps:
            r = by_dt.get(d)
            if r is None:
                cells.append("<td></td>")
            elif r["status"] != "ok":
                cells.append(f"<td class='fail' title='{_e(r.get('message', ''))}'>{_e(r['status'])}</td>")
            else:
                cells.append(f"<td class='num'>{r['attitude_error']:.1e}</td>")
        rates = [r["steps_per_second"] for r in e["runs"] if r.get("steps_per_second")]
        rate = f"{max(rates):.3g}" if rates else ""
        expected = e["expected_order"] if e["expected_order"] is not None else "adaptive"
        out.append(f"<tr><td class='{verdict_of(sc, m)}'>{_e(m)}</td><td>{expected}</td>"
                   f"<td class='num'>{_fmt(e['observed_order'], '.2f')}</td>{''.join(cells)}"
                   f"<td class='num'>{rate}</td></tr>")
    out.append("</table>")
    for file, caption in figs:
        data = base64.b64encode((plot_dir / file).read_bytes()).decode("ascii")
        out.append(f"<figure><img alt='{_e(caption)}' src='data:image/png;base64,{data}'>"
                   f"<figcaption>{_e(caption)}</figcaption></figure>")
    return out


def _html_appendix(results):
    out = ["<h2 id='appendix'>Appendix: throughput</h2>"]
    if results["throughput"]:
        out.append("<p class='small'>Steps per second (batch: body-steps per second).</p>")
        out.append("<table><tr><th>engine</th><th>method</th><th>scenario</th><th>batch</th><th>steps/s</th></tr>")
        for r in results["throughput"]:
            out.append(f"<tr><td>{_e(r['engine'])}</td><td>{_e(r['method'])}</td><td>{_e(r['scenario'])}</td>"
                       f"<td class='num'>{r['batch']}</td><td class='num'>{r['steps_per_second']:.3g}</td></tr>")
        out.append("</table>")
    else:
        out.append("<p>No throughput measured.</p>")
    return out
