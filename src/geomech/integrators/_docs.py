"""The methods table of docs/integrators.md, built from the registry (so the docs cannot drift)."""

from __future__ import annotations

import re

from .methods import REGISTRY, methods_table

HEADER = """# Integrators

`geomech.solve(system, method, *, y0 | m0 [, R0], h, t_final, ...)` integrates a system with a method; a
method is a small immutable value with its order and traits, and the structure it needs. An incompatible
pair fails before any work (`IncompatibleMethodError`, which names the methods that would apply). Numerical
failure (a Newton iteration that does not converge, a non-finite state) is status data in the `Solution`,
raised by default with the step, the time and the residual.

Fixed-step methods run in loops compiled with numba from the symbolic model (cached on disk); adaptive
Adams wraps scipy's VODE/LSODA. `geomech.integrators.QuadraturePropagator` propagates one-degree-of-freedom
systems exactly by quadrature, at a cost that does not grow with t. Speed and accuracy beside scipy and
heyoka: `benchmarks/README.md`.

This table is generated from `geomech.integrators.REGISTRY` (`python -m geomech.integrators._docs`).

"""


def _summary(key: str) -> str:
    """The first sentence of the method's docstring, its first paragraph joined, markup made plain."""
    doc = (type(REGISTRY[key]).__doc__ or "").strip().split("\n\n")[0]
    text = " ".join(line.strip() for line in doc.splitlines())
    text = re.sub(r":math:`([^`]*)`", r"`\1`", text).replace("``", "`")
    m = re.match(r"(.+?\.)(\s|$)", text)
    return (m.group(1) if m else text).rstrip(".")


def _order(row: dict) -> str:
    if row["variable_order"]:
        return f"1-{row['order']} (variable)"
    return "exact" if row["order"] == 0 else str(row["order"])


def table_markdown() -> str:
    rows = ["| key | method | order | structure needed | explicit | symplectic | symmetric | keeps Casimirs |",
            "|---|---|---|---|---|---|---|---|"]
    yes = {True: "yes", False: "no"}
    for r in methods_table():
        rows.append(
            f"| `{r['key']}` | {_summary(r['key'])} | {_order(r)} | {r['structure']} | {yes[r['explicit']]} | "
            f"{yes[r['symplectic']]} | {yes[r['symmetric']]} | {yes[r['preserves_casimirs']]} |"
        )
    return "\n".join(rows) + "\n"


def document() -> str:
    return HEADER + table_markdown()


if __name__ == "__main__":  # pragma: no cover
    print(document(), end="")
