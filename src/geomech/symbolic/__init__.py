"""The symbolic layer, below the mechanics: user formulas parsed by a whitelist (:mod:`.formula`), simplified
(:mod:`.simplify`, over the polynomial rings of :mod:`.polys`), compiled to numeric functions (:mod:`.compile`)
and their derivations cached in memory and on disk (:mod:`.cache`)."""

from ._derivative import derivative, jacobian
from .cache import DISK_CACHE, DiskCache, NumericCache, shared_property, shared_value
from .charts import GroupChart, group_chart
from .compile import (
    M_SYMBOLS,
    bind_expression,
    column,
    compile_matrix,
    compile_scalar,
    compile_vector,
    evaluate,
    stack_last,
    suffixed_symbols,
)
from .formula import FUNCTIONS, parse_formula, to_expression
from .polys import expand_terms
from .simplify import (
    clear_denominators,
    half_quadratic,
    inverse,
    quadratic_blocks,
    quadratic_coefficients,
    quadratic_form,
    simplified_inverse,
    simplify_expr,
    simplify_matrix,
    tidy_trig,
    time_derivative,
    vanishes,
)

__all__ = [
    "derivative",
    "jacobian",
    "GroupChart",
    "group_chart",
    "DISK_CACHE",
    "DiskCache",
    "NumericCache",
    "shared_property",
    "shared_value",
    "M_SYMBOLS",
    "bind_expression",
    "column",
    "suffixed_symbols",
    "compile_matrix",
    "compile_scalar",
    "compile_vector",
    "evaluate",
    "stack_last",
    "FUNCTIONS",
    "parse_formula",
    "to_expression",
    "clear_denominators",
    "expand_terms",
    "half_quadratic",
    "inverse",
    "quadratic_blocks",
    "quadratic_coefficients",
    "quadratic_form",
    "simplified_inverse",
    "simplify_expr",
    "simplify_matrix",
    "tidy_trig",
    "time_derivative",
    "vanishes",
]
