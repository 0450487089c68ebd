"""The compiled tick's measurements as pages: ``docs/performance/compiled.md`` and the
README's performance table, from ``benchmarks/results/compiled/perf.json`` (an
``mpc-bench perf --sections compiled,peers`` run; :mod:`benchmarks.docs_pages` writes them).

The README's table is one row a layout over the scenarios the run measured (time and path
mode, inside and beyond the limits) on the first plant of the run; the page has every
scenario on every plant, issue 37's lines per plant and the scenarios the compiled tick
refused, with why.
"""

from __future__ import annotations

import textwrap
from typing import Any

from benchmarks.markdown import sig, table

Row = dict[str, Any]

#: The README's generated performance block lies between these two lines.
BEGIN, END = "<!-- performance:begin -->", "<!-- performance:end -->"
#: The folder of the run under ``benchmarks/results``.
FOLDER = "compiled"

#: Issue 37's lines as the page names them.
LINES = {
    "mecanum_inside_do_mpc_over_compiled_tick": "Mecanum inside: do-mpc / compiled tick p50",
    "mecanum_inside_ipopt_over_compiled_tick": "Mecanum inside: IPOPT / compiled tick p50",
    "mecanum_inside_compiled_rms_over_ipopt_rms": "Mecanum inside: RMS compiled / IPOPT",
    "ipopt_over_compiled_tick_min": "IPOPT / compiled tick p50, every scenario",
    "compiled_p99_over_p50_max": "wall-clock p99 / p50, every scenario",
    "compiled_tick_p99_max": "wall-clock p99 [ms], every scenario",
    "compiled_cpu_p99_over_p50_max": "process-CPU p99 / p50, every scenario",
    "compiled_cpu_p99_max": "process-CPU p99 [ms], every scenario",
}


def _ms(seconds: float) -> str:
    return f"{1e3 * seconds:.3f}"


def _machine(perf: dict[str, Any]) -> str:
    machine = perf.get("machine", {})
    load = machine.get("load_average_start", [None])[0]
    end = machine.get("load_average_end", [None])[0]
    loads = f", load average {load:.1f} at the start, {end:.1f} at the end" if (
        load is not None and end is not None) else ""
    return (f"{machine.get('cpu_count', '?')} cores ({machine.get('processor', '?')}), "
            f"Python {machine.get('python', '?')}{loads}")


def _rows(perf: dict[str, Any], solver: str, plant: str) -> list[Row]:
    return [row for row in perf["rows"] if row["section"] == "compiled"
            and row["solver"] == solver and row.get("plant", "ideal") == plant
            and row.get("run", 1) == 1]


def _plants(perf: dict[str, Any]) -> list[str]:
    return list(perf["settings"].get("plants", ["ideal"]))


def _key(row: Row) -> tuple[str, str, str]:
    return row["layout"], row["mode"], row["speed"]


def _header(perf: dict[str, Any]) -> str:
    return (f"`{perf['command']}` on {_machine(perf)}, commit "
            f"`{(perf.get('commit') or '?')[:10]}`")


def readme_block(perf: dict[str, Any]) -> str:
    """The README's performance table: one row a layout on the run's first plant."""
    plant = _plants(perf)[0]
    compiled = _rows(perf, "compiled", plant)
    python = {_key(row): row for row in _rows(perf, "python", plant)}
    refused: dict[str, int] = {}
    for item in perf.get("compiled", {}).get("unsupported", []):
        refused[item["layout"]] = refused.get(item["layout"], 0) + 1
    layouts = list(dict.fromkeys([row["layout"] for row in compiled] + list(refused)))
    rows = []
    for layout in layouts:
        own = [row for row in compiled if row["layout"] == layout]
        total = len(own) + refused.get(layout, 0)
        if not own:
            rows.append([layout, f"0 of {total}", "", "", "", ""])
            continue
        p50 = sorted(row["tick_p50"] for row in own)
        speedup = [python[_key(row)]["tick_p50"] / row["tick_p50"] for row in own
                   if _key(row) in python]
        rows.append([
            layout, f"{len(own)} of {total}", f"{_ms(p50[0])}-{_ms(p50[-1])}",
            _ms(max(row["cpu_p99"] for row in own)),
            f"{sig(min(speedup))}-{sig(max(speedup))}" if speedup else "",
            sig(min(row["ipopt_over_compiled_tick"] for row in own))])
    lines = issue_lines(perf, plant)
    peers = {key: lines[key]["measured"] for key in (
        "mecanum_inside_do_mpc_over_compiled_tick", "mecanum_inside_ipopt_over_compiled_tick")
        if key in lines}
    peer_text = (f" Mecanum figure-eight inside the limits: do-mpc's tick "
                 f"{peers['mecanum_inside_do_mpc_over_compiled_tick']:.0f}x and IPOPT's "
                 f"{peers['mecanum_inside_ipopt_over_compiled_tick']:.0f}x the compiled "
                 "tick's (p50, same ticks)." if len(peers) == 2 else "")
    return "\n".join([
        table(["layout", "scenarios compiled", "compiled tick p50 [ms]",
                "process-CPU p99, worst [ms]", "Python tick / compiled", "IPOPT / compiled, least"],
               rows), "",
        textwrap.fill(
        f"Figure-eight, N = 20, dt 0.05 s, {plant} plant, time and path mode inside (0.8x) "
        f"and beyond (1.3x) the wheel limits; {_header(perf)}; a shared machine: compare "
        f"ratios within the run.{peer_text} Every scenario, both plants and the lines not "
        "met: [compiled tick performance](docs/performance/compiled.md).", 90,
        break_on_hyphens=False, break_long_words=False)])


def issue_lines(perf: dict[str, Any], plant: str) -> dict[str, dict[str, Any]]:
    """Issue 37's lines on ``plant`` (the summary's per-plant lines, or its only ones)."""
    summary = perf["summary"]
    by_plant = summary.get("issue37_plants") or {}
    return dict(by_plant.get(plant) or summary.get("issue37") or {})


def page(perf: dict[str, Any], text: str, notice: str) -> str:
    """``docs/performance/compiled.md``: every scenario of the run on every plant."""
    out = [notice, "", "# The compiled tick: every scenario", "",
           f"{_header(perf)}; {perf['settings']['ticks']} ticks a run (IPOPT "
           f"{perf['settings']['ipopt_ticks']}), {perf['wall_time'] / 60:.0f} minutes in all. "
           f"Files: `benchmarks/results/{FOLDER}/perf.json` and `perf.txt`. The machine is "
           "shared: the ratios (within the run, on the same ticks) are what to compare; "
           "wall-clock p99 is mostly the time the scheduler gave other processes, so the "
           "process-CPU p99 is given beside it. What each row is: "
           "[the compiled tick](../guide/compiled-tick.md).", ""]
    for plant in _plants(perf):
        python = {_key(row): row for row in _rows(perf, "python", plant)}
        machine = {_key(row): row for row in _rows(perf, "virtual-machine", plant)}
        exported = {_key(row): row for row in _rows(perf, "exported", plant)}
        rows = []
        for row in _rows(perf, "compiled", plant):
            key = _key(row)
            rows.append([
                *key, _ms(row["tick_p50"]), _ms(row["cpu_p99"]),
                sig(python[key]["tick_p50"] / row["tick_p50"]) if key in python else "",
                sig(machine[key]["tick_p50"] / row["tick_p50"]) if key in machine else "",
                sig(exported[key]["tick_p50"] / row["tick_p50"]) if key in exported else "",
                sig(row["ipopt_over_compiled_tick"]), sig(1e3 * row["rms_position_error"])])
        lines = []
        for name, item in issue_lines(perf, plant).items():
            scale = 1e3 if name.endswith("p99_max") else 1.0  # seconds shown in ms
            sense = "at least" if item.get("at_least") else "at most"
            lines.append([LINES.get(name, name), sig(scale * item["measured"], 4),
                          f"{sense} {sig(scale * item['limit'])}", item.get("scenario", ""),
                          "met" if item["met"] else "**not met**"])
        out += [f"## The {plant} plant", "",
                table(["layout", "mode", "speed", "compiled p50 [ms]", "CPU p99 [ms]",
                        "Python / compiled", "virtual machine / compiled",
                        "exported (in C) / compiled", "IPOPT / compiled", "RMS error [mm]"],
                       rows), "", "Issue 37's lines:", "",
                table(["line", "measured", "limit", "worst scenario", ""], lines), ""]
    refused = perf.get("compiled", {}).get("unsupported", [])
    if refused:
        out += ["## Not compiled", "",
                table(["layout", "mode", "speed", "why"],
                       [[item["layout"], item["mode"], item["speed"],
                         item["reason"].split("; it supports")[0]] for item in refused]), ""]
    out += ["## The run's output", "", "```text", text.rstrip(), "```", ""]
    return "\n".join(out)
