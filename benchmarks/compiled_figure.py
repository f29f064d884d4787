"""The figure of issue 16's single runs beside heyoka: work against precision for the snakeboard, the roller racer
and the Chaplygin sleigh (``results/nonholonomic.json``) and the body with three rotors (``results/rotors.json``),
from the results the two benchmarks wrote (it runs nothing).

Each panel: the state error at the end against heyoka in quadruple precision (the benchmarks' reference), over the
wall time; heyoka's ``taylor_adaptive`` (its propagation, its construction apart), and geomech's Taylor method and
compiled DOP853 three ways: from the Python call (``solve``), from a prepared problem's call
(``prepare(...).solve(...)``) and the compiled loop alone. The gap between a method's loop and its calls is the
Python around the loop; the dotted line is twice heyoka's time (issue 16's target), at heyoka's errors.

    PYTHONPATH=src python benchmarks/nonholonomic.py && PYTHONPATH=src python benchmarks/rotors.py
    python benchmarks/compiled_figure.py          # writes benchmarks/compiled_vs_heyoka.png
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
#: geomech's rows drawn in each panel (the benchmarks' ``who``), the nonholonomic systems' then the rotors'
SERIES = {
    "nonholonomic": {
        "Taylor": "geomech BKMM Taylor compiled",
        "Taylor, work=False": "geomech BKMM Taylor (work=False) compiled",
        "DOP853": "geomech BKMM compiled (DOP853)",
    },
    "rotors": {"Taylor": "geomech taylor (compiled)", "DOP853": "geomech dop853 (compiled)"},
}
HEYOKA = "heyoka taylor_adaptive"
#: the three times of a geomech row: its key in the results, the line's style
TIMES = (("wall_ms", "from solve", "-"), ("prepared_ms", "prepared", "--"), ("loop_ms", "loop alone", ":"))
COLORS = {"Taylor": "tab:blue", "Taylor, work=False": "tab:green", "DOP853": "tab:orange"}


def panels(nonholonomic: dict[str, Any], rotors: dict[str, Any]) -> list[tuple[str, str, list[dict[str, Any]]]]:
    """(title, kind, rows) of each panel: the nonholonomic cases, then the rotors."""
    out = []
    for case in nonholonomic["cases"]:
        title = f"{case['problem'].replace('_', ' ')}, t = {case['t_final']:g}"
        out.append((title, "nonholonomic", case["rows"]))
    out.append((f"three rotors, 2 tan(v/G), t = {rotors['problem']['t_final']:g}", "rotors", rotors["rows"]))
    return out


def figure(nonholonomic: dict[str, Any], rotors: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    made = panels(nonholonomic, rotors)
    cols = 2
    nrows = -(-len(made) // cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(6.0 * cols, 4.6 * nrows), squeeze=False)
    for ax, (title, kind, rows) in zip(axes.ravel(), made):
        peer = sorted((r for r in rows if r["who"] == HEYOKA), key=lambda r: r["error"])
        ax.loglog([r["wall_ms"] for r in peer], [r["error"] for r in peer], "k-X", ms=7, label="heyoka")
        ax.loglog([2 * r["wall_ms"] for r in peer], [r["error"] for r in peer], color="0.5", ls=":", lw=1.0,
                  label="2 x heyoka")  # fmt: skip
        for name, who in SERIES[kind].items():
            mine = sorted((r for r in rows if r["who"] == who), key=lambda r: r["error"])
            for key, what, ls in TIMES:
                ax.loglog([r[key] for r in mine], [r["error"] for r in mine], ls=ls, marker="o", ms=4,
                          color=COLORS[name], label=f"{name}, {what}")  # fmt: skip
        ax.set_title(title)
        ax.set_xlabel("wall time (ms), best of repeats, compilation excluded")
        ax.set_ylabel("state error at the end (max norm)")
        ax.grid(True, which="major", alpha=0.4)
        ax.xaxis.set_minor_formatter(NullFormatter())  # (the minor ticks' labels overlap)
    for ax in axes.ravel()[len(made) :]:
        ax.set_visible(False)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=100)
    plt.close(fig)
    tmp.replace(path)  # written whole or not at all


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--results", type=Path, default=HERE / "results", help="the benchmarks' JSON results")
    parser.add_argument("--figure", type=Path, default=HERE / "compiled_vs_heyoka.png")
    args = parser.parse_args(argv)
    nonholonomic = json.loads((args.results / "nonholonomic.json").read_text())
    rotors = json.loads((args.results / "rotors.json").read_text())
    figure(nonholonomic, rotors, args.figure)
    print(args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
