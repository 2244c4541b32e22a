"""The robustness report as one self-contained HTML page: the table per condition and two plots, inline.

Survival per condition with its 95 % interval, and for pushes the survival curve over impulse
per setup; then criteria missed and episodes that failed to run. Plots are PNG in data URIs,
so the page is a single file to mail or attach.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Any

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

STYLE = (
    "body{font-family:sans-serif;margin:2em;max-width:70em}table{border-collapse:collapse}"
    "td,th{border:1px solid #ccc;padding:.3em .6em;text-align:right}td:first-child,th:first-child{text-align:left}"
    ".bad{background:#fdd}.good{background:#dfd}"
)


def write_html(report: dict[str, Any], path: Path) -> None:
    conditions = report["conditions"]
    rows = []
    for group, f in conditions.items():
        survival = f["survival"]
        css = "good" if survival == 1.0 else "bad" if survival is not None and survival < 0.9 else ""
        low, high = f["survival_ci95"]
        cells = [html.escape(group), f["episodes"], f["falls"], "-" if survival is None else f"{survival:.2f}", f"{low:.2f}-{high:.2f}",
                 "-" if f["velocity_error_mean"] is None else f"{f['velocity_error_mean']:.3f}", f["failed_episodes"]]  # fmt: skip
        rows.append(f'<tr class="{css}">' + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("condition", "episodes", "falls", "survival", "95 % interval", "velocity error m/s", "failed"))
    curves = report.get("push_curves", {})
    impulse = "".join(
        f"<li>{html.escape(setup)}: {c['impulse_survived_at_90_ns'] if c['impulse_survived_at_90_ns'] is not None else 'none'} N s</li>"
        for setup, c in curves.items()
    )
    pushes = ""
    if curves:
        plot = f'<img alt="survival over impulse" src="{_curve_plot(curves)}">'
        pushes = f"<h2>Pushes</h2><p>Largest impulse survived by 90 % of episodes:</p><ul>{impulse}</ul>{plot}"
    drills = _drill_table(conditions)
    problems = [*report["criteria_failures"], *(f"{e['id']}: {e.get('error', '')}" for e in report["episodes"] if e["status"] != "done")]
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(report["suite"])}</title><style>{STYLE}</style></head>
<body><h1>Robustness: {html.escape(report["suite"])}</h1><p>{html.escape(report.get("description", ""))}</p>
<p>{len(report["episodes"])} episodes, {report["workers"]} workers, {report["wall_seconds"]} s.</p>
<table><tr>{head}</tr>{"".join(rows)}</table>
<h2>Survival per condition</h2><img alt="survival per condition" src="{_survival_plot(conditions)}">
{pushes}{drills}
<h2>Criteria missed and episodes lost</h2><ul>{"".join(f"<li>{html.escape(p)}</li>" for p in problems) or "<li>none</li>"}</ul>
</body></html>
"""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(page)


def _drill_table(conditions: dict[str, dict[str, Any]]) -> str:
    """Per drill: passed of run, the slowest time to every motor safe against the plan's, commands outside the limits on the wire."""
    rows = []
    for group, f in conditions.items():
        if not f.get("drills"):
            continue
        css = "good" if f["drills_passed"] == f["drills"] and not f.get("outside_limits") else "bad"
        latency, stated = f.get("damping_latency_max_s"), f.get("within_s")
        cells = [html.escape(group), f"{f['drills_passed']} of {f['drills']}", "-" if latency is None else f"{1e3 * latency:.0f}",
                 "-" if stated is None else f"{1e3 * stated:.0f}", f.get("outside_limits", "-")]  # fmt: skip
        rows.append(f'<tr class="{css}">' + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    if not rows:
        return ""
    head = "".join(f"<th>{h}</th>" for h in ("drill", "passed", "every motor safe after (ms)", "stated (ms)", "outside limits on the wire"))
    intro = "<h2>Fault drills</h2><p>Judged on what the emulated motors decoded from the frames.</p>"
    return f"{intro}<table><tr>{head}</tr>{''.join(rows)}</table>"


def _figure(width: float, height: float) -> tuple[Figure, Any]:
    """A figure and its axes on the Agg canvas (no pyplot: no global backend chosen, nothing left open)."""
    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig, fig.subplots()


def _data_uri(fig: Figure) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode()


def _survival_plot(conditions: dict[str, dict[str, Any]]) -> str:
    names = list(conditions)
    survival = [c["survival"] or 0.0 for c in conditions.values()]
    low = [s - c["survival_ci95"][0] for s, c in zip(survival, conditions.values(), strict=True)]
    high = [c["survival_ci95"][1] - s for s, c in zip(survival, conditions.values(), strict=True)]
    fig, ax = _figure(9, max(2.0, 0.28 * len(names)))
    ax.barh(range(len(names)), survival, xerr=[low, high], color="tab:blue", ecolor="gray")
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.set_xlim(0, 1.05)
    ax.set_xlabel("survival (95 % interval)")
    ax.invert_yaxis()
    return _data_uri(fig)


def _curve_plot(curves: dict[str, dict[str, Any]]) -> str:
    fig, ax = _figure(7, 4)
    for setup, curve in curves.items():
        ax.plot(curve["impulse_ns"], curve["survival"], marker="o", label=setup)
    ax.axhline(0.9, color="gray", linestyle="--", linewidth=0.8)
    ax.set_xlabel("push impulse (N s)")
    ax.set_ylabel("survival")
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=6)
    return _data_uri(fig)
