"""RouteParams' route-filter fields and the core's RouteFilterParams hold the same defaults: the
Python default of every field the core takes (``filter_<name>``, and the shared ``vmin``/``vmax``)
equals the default-constructed struct's."""

from __future__ import annotations

import dataclasses

from nightloc import _core
from nightloc.route.params import RouteParams

#: Core fields that RouteParams holds without the ``filter_`` prefix (shared with SeqSLAM).
_SHARED = {"vmin", "vmax"}


def _core_fields() -> dict[str, object]:
    core = _core.RouteFilterParams()
    names = [n for n in dir(core) if not n.startswith("_") and not callable(getattr(core, n))]
    return {n: getattr(core, n) for n in names}


def test_every_core_field_has_the_python_default():
    defaults = {f.name: f.default for f in dataclasses.fields(RouteParams)}
    core = _core_fields()
    assert core, "the core's RouteFilterParams binds no fields"
    for name, value in core.items():
        python = name if name in _SHARED else f"filter_{name}"
        assert python in defaults, f"RouteParams has no field {python} for the core's {name}"
        assert defaults[python] == value, f"{python}: Python {defaults[python]!r}, core {value!r}"


def test_the_conversion_gives_the_core_defaults():
    core = _core_fields()
    converted = RouteParams().core_filter_params()
    assert {n: getattr(converted, n) for n in core} == core
