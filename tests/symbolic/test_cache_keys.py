"""The disk cache's keys: printed as sympy's srepr prints them (the same file names in every process), each part
once per process (a three-link chain's system key is 120,000 characters: every look-up printed it again)."""

import sympy as sp

from geomech.symbolic import cache


def test_a_key_prints_as_srepr_and_its_parts_once(monkeypatch):
    x, y = sp.symbols("x y", real=True)
    big = sp.Matrix([[sp.sin(x) * y + 1, x**2], [sp.Rational(1, 3), sp.Float(2.5)]]).as_immutable()
    keys = [
        ("NonholonomicReduction", (big, (x, y)), "momentum_coefficients"),
        ("a", (1,), True, 1, 1.0, None, ()),
        (big,),
        "text",
    ]
    for key in keys:
        assert cache.key_text(key) == sp.srepr(key)
    calls = []
    original = cache.sp.srepr
    monkeypatch.setattr(cache.sp, "srepr", lambda e: calls.append(e) or original(e))
    cache._TEXT.clear()
    first = cache.key_text((big, "one"))
    again = cache.key_text(("other", big, "two"))
    assert first.startswith("(" + original(big)) and original(big) in again
    assert sum(c is big for c in calls) == 1  # the large part printed once
    # values equal across types keep their own text (1, True and 1.0 hash alike)
    assert [cache.key_text(v) for v in (1, True, 1.0)] == ["1", "True", "1.0"]
